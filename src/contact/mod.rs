//! Contact solvers. `qp`: the dense box- and equality-constrained QP in the contact multipliers
//! that the exact direct solver (SPEC §3.1) condenses the Signorini–Tresca problem into.

pub mod qp;
