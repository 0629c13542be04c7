"""Emulators of the forward model trained on a campaign: Gaussian process and MLP."""
