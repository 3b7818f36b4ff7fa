"""Bridges that let other libraries use jaxdpd's components (see docs/jax_md_interop.md)."""
