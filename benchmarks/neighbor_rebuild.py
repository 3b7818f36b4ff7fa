"""Cost of one neighbour-list rebuild: jaxdpd's cell list against jax-md's lists.

Uniform random configurations at ρ = 3, cut-off 1, skin 0.3 for both.  Each
backend's jitted `update` is timed on positions displaced by more than half the skin,
so every call rebuilds.  The ratio is measured in the same run.

Usage: python benchmarks/neighbor_rebuild.py [--sizes 3000 24000] [--repeats 5]
Writes benchmarks/results/neighbor_rebuild.json.
"""

import argparse
import time

import jax
import jax.numpy as jnp
from _common import print_table, write_json

from jaxdpd.geometry.boxes import PeriodicBox
from jaxdpd.geometry.neighbors import neighbor_search


def rebuild_seconds(search, positions, displaced, repeats: int) -> float:
    pair_list = search.allocate(positions)
    update = jax.jit(search.update)
    jax.block_until_ready(update(displaced, pair_list))
    start = time.perf_counter()
    for _ in range(repeats):
        jax.block_until_ready(update(displaced, pair_list))
    return (time.perf_counter() - start) / repeats


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[3000, 24000])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    rows = []
    for n in args.sizes:
        side = (n / 3.0) ** (1 / 3)
        box = PeriodicBox((side, side, side))
        key = jax.random.PRNGKey(0)
        positions = jax.random.uniform(key, (n, 3), jnp.float32) * side
        displaced = jnp.mod(positions + 0.2, side)
        cells = rebuild_seconds(
            neighbor_search(box, n, 1.0, 0.3), positions, displaced, args.repeats
        )
        for fmt in ("dense", "ordered_sparse"):
            search = neighbor_search(box, n, 1.0, 0.3, "jax_md", fmt)
            other = rebuild_seconds(search, positions, displaced, args.repeats)
            rows.append(
                {
                    "N": n,
                    "jax_md_format": fmt,
                    "jax_md_ms": 1e3 * other,
                    "cell_list_ms": 1e3 * cells,
                    "speed-up": other / cells,
                }
            )
            print_table(list(rows[-1]), rows[-1:])
    print()
    print_table(list(rows[0]), rows)
    print(f"wrote {write_json('neighbor_rebuild', {'rows': rows})}")


if __name__ == "__main__":
    main()
