"""`adaptive_qp`: the adaptive-gain QP of 002 Sec. V, its policy and its problem."""
