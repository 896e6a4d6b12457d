"""Scene files (TOML) to a validated Scene and its ThermalSystem: file, geometry, sensors."""
