"""The results store, the sweep runner, the CI regression check and the benchmark."""
