"""Whole-body control: Pinocchio model terms, tasks, and the adaptive-gain QP."""
