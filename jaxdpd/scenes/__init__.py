"""Embedded scenes (TOML) shipped with the package."""
