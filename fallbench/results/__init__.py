"""The results store, the sweep runner and the CI regression check."""
