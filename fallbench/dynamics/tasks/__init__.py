"""Set-point tasks of the whole-body QP, one per file: error, Jacobian, J_dot q_dot."""
