"""Post-impact gain policies: the `GainPolicy` interface in `base.py`, one policy per module or
package; registered by name in `fallbench.registry`."""
