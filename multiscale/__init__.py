"""Multi-scale static-friction theory and the statistical CKE/LET models (NumPy only)."""
