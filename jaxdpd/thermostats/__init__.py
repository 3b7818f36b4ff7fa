"""Thermostats and solvent momentum-exchange rules."""
