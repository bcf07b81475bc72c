//! Output formats: VTU files for ParaView.

pub mod vtu;
