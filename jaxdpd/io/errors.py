"""The errors raised for output files, and the opener that turns h5py's into them."""

import contextlib

import h5py


class RunFileError(ValueError):
    """A file is not a readable jaxdpd H5MD file: missing, truncated, corrupted, or
    written for another scene or version.  The message names the file and the part."""


class OutputError(RuntimeError):
    """Writing the output failed (disk full, I/O error, file system gone).

    Nothing was wrong with the input, so this is not a RunFileError: the command line
    exits with its own status.  The last checkpoint written before the failure is
    intact (checkpoints replace their file atomically), so the run can be resumed
    once the cause is removed.
    """


def first_line(error) -> str:
    """The first line of an exception's text (HDF5's run over several)."""
    text = str(error).strip()
    return text.splitlines()[0] if text else type(error).__name__


@contextlib.contextmanager
def open_run_file(path, mode: str = "r"):
    """Open an HDF5 file, turning every h5py failure inside the block into
    RunFileError naming the file."""
    try:
        handle = h5py.File(str(path), mode)
    except FileNotFoundError:
        raise RunFileError(f"{path}: no such file") from None
    except OSError as error:
        raise RunFileError(f"{path}: not a readable HDF5 file ({first_line(error)})") from None
    try:
        yield handle
    except (OSError, KeyError, RuntimeError) as error:
        raise RunFileError(f"{path}: damaged or incomplete ({first_line(error)})") from None
    finally:
        with contextlib.suppress(Exception):
            handle.close()
