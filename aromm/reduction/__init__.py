"""Reduced models: modal bases, corrections, reductors, the offline pipeline, the online ReducedModel."""
