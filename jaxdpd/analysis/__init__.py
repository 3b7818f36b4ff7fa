"""Host-side estimators: fits, Green–Kubo, rheology, statistics of series."""
