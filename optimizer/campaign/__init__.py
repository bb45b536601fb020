"""Optimisation campaigns: YAML-configured, parallel, resumable NSGA-II runs over the evaluation pipeline."""
