"""`reshape`: pre-impact posture reshaping and landing-point search (002 Sec. IV, 000 Sec. IV)."""
