"""The full-order model: steady and transient solves of a ThermalSystem."""
