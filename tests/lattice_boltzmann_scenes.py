"""The packaged Kremer–Grest chain scene (jaxdpd/scenes/lb_chain.toml) as a dictionary,
for tests that vary it."""

import copy
import tomllib
from importlib import resources

LB_CHAIN = tomllib.loads(resources.files("jaxdpd.scenes").joinpath("lb_chain.toml").read_text())


def lb_chain_scene(**sections) -> dict:
    """The scene dictionary with whole sections replaced (None removes one)."""
    data = copy.deepcopy(LB_CHAIN)
    for name, value in sections.items():
        if value is None:
            data.pop(name, None)
        else:
            data[name] = value
    return data
