"""Wrapping keeps r + image · L equal to the unwrapped position at the float32 edges."""

import jax.numpy as jnp
import numpy as np

from jaxdpd.geometry.boxes import PeriodicBox


def test_wrap_counts_the_round_off_folds_at_the_box_edges():
    """−tiny wraps to L − tiny, which rounds to L in float32 and is folded to 0; a
    coordinate just below a multiple of L can round r/L up to an integer and leave a
    tiny negative remainder.  Both folds must enter the image counter (a miscounted
    fold moves the unwrapped position by a whole box edge, which broke chains and
    mean-square displacements in long float32 runs)."""
    box = PeriodicBox((18.0, 18.0, 18.0))
    raw = np.array([[-1e-9, 18.0 - 1e-7, 35.99999], [-18.0000001, 0.0, 17.9999999]])
    positions = jnp.asarray(raw, jnp.float32)
    wrapped, image = box.wrap(positions, jnp.zeros((2, 3), jnp.int32))
    wrapped = np.asarray(wrapped)
    assert np.all((wrapped >= 0) & (wrapped < 18.0))
    unwrapped = wrapped.astype(np.float64) + 18.0 * np.asarray(image)
    np.testing.assert_allclose(unwrapped, np.asarray(positions, np.float64), atol=2e-6)
