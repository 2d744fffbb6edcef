"""The shared whole-body layer: Pinocchio model terms, contact rows, tasks, limits, one QP builder
and the solver wrappers; every QP of fallbench is built from it."""
