//! Output formats: the JSON summary and full result of a solve, and VTU files for ParaView.

pub mod result;
pub mod vtu;
