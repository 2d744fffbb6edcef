"""The simulated fall: the MuJoCo world, the servo, the fall and impact detectors, and the
episode loop that records one fall."""
