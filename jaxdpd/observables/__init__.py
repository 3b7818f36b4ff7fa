"""Observables: per-step samples inside the scan, chunk-end samples outside it."""
