//! Worst-scenario analysis (SPEC §4): the admissible set, the criteria Φ1–Φ6 and the outer
//! maximiser. So far only the generic maximiser over a box (`search`, SPEC §4.3) lives here.

pub mod search;
