"""Validation: independent engines built from the exported models, the paper's printed
numbers, reports."""
