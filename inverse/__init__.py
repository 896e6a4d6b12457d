"""inverse: identification of phase properties from measurements (seed 001 section 4)."""
