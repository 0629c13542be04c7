"""Inference: what is done after a test (experiment data and its processing, synthetic experiments,
the inverse fit, posteriors, the model-error check, the FE confirmation)."""
