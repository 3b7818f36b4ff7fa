"""Any pytree (a SimState, say) to and from an HDF5 group, leaf for leaf, bit for bit.

Nothing here knows the fields of the state: a field someone adds to `SimState` (a
lattice-Boltzmann `solvent_state`, a Lees–Edwards box state, ...) is stored and
restored without touching this module.

Layout of a stored tree:

    <group>
     +-- statics: JSON {path: value} of the static (non-array) dataclass fields
     \\-- <path>                 one dataset per array leaf, named by its tree path
          +-- crc32              checksum of the leaf's bytes (detects corruption)

Leaf names join the keys of the leaf's tree path with "/" (attribute names, dict
keys, sequence indices), so `state.pair_list.i` is stored at `<group>/pair_list/i`.

Static fields (e.g. `PairList.cell_capacity`, jax-md's `max_occupancy`) are part of
the tree structure, not leaves.  Those of JSON type (numbers, strings, booleans, None
and tuples of them) are stored with their type and restored (the template's must be
of the same type).  Others (functions, enums) cannot be
stored; they are taken from the template the tree is restored into (the state built
from the same scene), after checking that their text (address stripped) matches what
was written.

Restoring needs a template of the same structure (`read_tree(group, template)`):
leaf values, dtypes and shapes come from the file (a shape may differ from the
template's, e.g. a neighbour list reallocated during the run); the structure and the
non-JSON statics come from the template.
"""

import dataclasses
import json
import re
import zlib

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.io.errors import RunFileError

STATICS_ATTRIBUTE = "statics"
CHECKSUM_ATTRIBUTE = "crc32"
_ADDRESS = re.compile(r" at 0x[0-9a-fA-F]+")


def _key_name(key) -> str:
    """The text of one tree-path key ('/' escaped, as it separates keys)."""
    for field in ("name", "key", "idx"):
        if hasattr(key, field):
            return str(getattr(key, field)).replace("/", "%2F")
    raise TypeError(f"unsupported pytree key {key!r}")


def leaf_name(path) -> str:
    """The dataset name of a leaf from its `jax.tree_util` key path."""
    return "/".join(_key_name(key) for key in path)


def _children(node):
    """(key, child) pairs one level down, and the treedef that rebuilds the node."""
    pairs, treedef = jax.tree_util.tree_flatten_with_path(node, is_leaf=lambda x: x is not node)
    return [(path[0] if path else None, child) for path, child in pairs], treedef


def _is_json_static(value) -> bool:
    if value is None or isinstance(value, (bool, int, float, str)):
        return True
    if isinstance(value, (tuple, list)):
        return all(_is_json_static(item) for item in value)
    return False


def _static_record(value):
    """What the file keeps of a static field: the value and its type, or its text."""
    if _is_json_static(value):
        return {"value": value, "type": type(value).__name__}
    return {"text": _ADDRESS.sub("", repr(value))}


def _deep_tuple(value):
    """JSON arrays back into (nested) tuples."""
    return tuple(_deep_tuple(v) for v in value) if isinstance(value, list) else value


def _map_statics(node, visit, path: str = ""):
    """Rebuild `node` with every static dataclass field replaced by
    `visit(path, value)`; children are visited first, depth first."""
    pairs, treedef = _children(node)
    is_dataclass = dataclasses.is_dataclass(node) and not isinstance(node, type)
    if jax.tree_util.treedef_is_leaf(treedef) and not is_dataclass:
        return node  # an array leaf, None or an empty container
    rebuilt = [_map_statics(child, visit, f"{path}/{_key_name(key)}") for key, child in pairs]
    node = jax.tree_util.tree_unflatten(treedef, rebuilt)
    if is_dataclass:
        data = {_key_name(key) for key, _ in pairs}
        changes = {
            field.name: visit(f"{path}/{field.name}", getattr(node, field.name))
            for field in dataclasses.fields(node)
            if field.init and field.name not in data
        }
        if changes:
            node = dataclasses.replace(node, **changes)
    return node


def static_fields(tree) -> dict:
    """{path: record} of the static dataclass fields anywhere in `tree`."""
    found = {}

    def record(path, value):
        found[path.lstrip("/")] = _static_record(value)
        return value

    _map_statics(tree, record)
    return found


def write_tree(group, tree) -> None:
    """Store every array leaf of `tree` and its static fields in `group`.

    Datasets of an earlier tree of the same structure are overwritten in place when
    shape and dtype agree (periodic checkpoints then do not grow the file), and
    replaced otherwise.

    Args:
        group: an open, writable h5py Group.
        tree: a pytree whose leaves are arrays (NumPy or JAX).
    """
    written = set()
    for path, leaf in jax.tree_util.tree_flatten_with_path(tree)[0]:
        name = leaf_name(path)
        value = np.asarray(leaf)
        written.add(name)
        existing = group.get(name)
        if existing is not None and (existing.shape, existing.dtype) == (value.shape, value.dtype):
            existing[()] = value
        else:
            if existing is not None:
                del group[name]
            existing = group.create_dataset(name, data=value)
        existing.attrs[CHECKSUM_ATTRIBUTE] = np.uint32(zlib.crc32(value.tobytes()))
    for stale in set(stored_leaf_names(group)) - written:
        del group[stale]
        parent = stale.rpartition("/")[0]
        while parent and not len(group[parent]):  # drop groups left empty
            del group[parent]
            parent = parent.rpartition("/")[0]
    group.attrs[STATICS_ATTRIBUTE] = json.dumps(static_fields(tree), sort_keys=True)


def stored_leaf_names(group) -> list[str]:
    """Names of the leaf datasets under `group` (relative paths)."""
    names = []
    group.visititems(lambda name, item: names.append(name) if hasattr(item, "dtype") else None)
    return names


def read_leaf(group, name: str) -> np.ndarray:
    """One stored leaf as a NumPy array, its checksum verified.

    Raises:
        RunFileError: the leaf is missing, unreadable or fails its checksum.
    """
    if name not in group:
        raise RunFileError(f"{group.file.filename}: {group.name}/{name} is missing")
    dataset = group[name]
    try:
        value = dataset[()]
    except OSError as error:
        raise RunFileError(
            f"{group.file.filename}: {dataset.name} is unreadable ({error})"
        ) from None
    value = np.asarray(value)
    expected = dataset.attrs.get(CHECKSUM_ATTRIBUTE)
    if expected is None or zlib.crc32(value.tobytes()) != int(expected):
        raise RunFileError(
            f"{group.file.filename}: {dataset.name} fails its checksum (the file is corrupted)"
        )
    return value


def read_tree(group, template):
    """The tree stored in `group`, with the structure of `template`.

    Args:
        group: an h5py Group written by `write_tree`.
        template: a tree of the same structure (same leaf paths, same dtypes, same
            kinds of static fields), e.g. the initial state of the same scene.
    Returns:
        The stored tree: JAX arrays with the stored dtypes, shapes and bits, statics
        from the file where storable and from the template otherwise.
    Raises:
        RunFileError: the stored tree does not fit the template, or is corrupted.
    """
    where = f"{group.file.filename}: {group.name}"
    try:
        stored_statics = json.loads(group.attrs[STATICS_ATTRIBUTE])
    except (KeyError, ValueError, TypeError) as error:
        raise RunFileError(f"{where}: missing or unreadable static fields ({error})") from None

    def restore(path, value):
        path = path.lstrip("/")
        mine = _static_record(value)
        theirs = stored_statics.get(path)
        if theirs is None or theirs.keys() != mine.keys() or theirs.get("type") != mine.get("type"):
            raise RunFileError(
                f"{where}: static field {path!r} is {theirs!r} in the file but "
                f"{mine!r} in this scene's state (written by another version?)"
            )
        if "text" in mine:
            if theirs != mine:
                raise RunFileError(
                    f"{where}: static field {path!r} was {theirs['text']!r}, "
                    f"this scene's state has {mine['text']!r}"
                )
            return value
        return _deep_tuple(theirs["value"]) if isinstance(value, tuple) else theirs["value"]

    template = _map_statics(template, restore)
    paths_and_leaves, treedef = jax.tree_util.tree_flatten_with_path(template)
    expected = {leaf_name(path) for path, _ in paths_and_leaves}
    extra = sorted(set(stored_leaf_names(group)) - expected)
    if extra:
        raise RunFileError(
            f"{where}: holds leaves {extra} that this scene's state does not have "
            "(written by another version of jaxdpd?)"
        )
    leaves = []
    for path, leaf in paths_and_leaves:
        name = leaf_name(path)
        value = read_leaf(group, name)
        dtype = np.asarray(leaf).dtype if not hasattr(leaf, "dtype") else np.dtype(leaf.dtype)
        if value.dtype != dtype or value.ndim != np.ndim(leaf):
            raise RunFileError(
                f"{where}/{name}: stored as {value.dtype}{list(value.shape)}, but this "
                f"scene's state has {dtype}{list(np.shape(leaf))}"
            )
        leaves.append(jnp.asarray(value))
    return jax.tree_util.tree_unflatten(treedef, leaves)
