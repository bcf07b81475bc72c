//! Bundled example scenes (`wsm example NAME`, `GET /v1/examples`), compiled into the binary
//! from `scenes/*.json`.

/// (name, JSON text) of every bundled scene.
pub const EXAMPLES: &[(&str, &str)] = &[
    (
        "block-on-base",
        include_str!("../../../scenes/block-on-base.json"),
    ),
    (
        "d03-model-problem",
        include_str!("../../../scenes/d03-model-problem.json"),
    ),
    (
        "heated-plate",
        include_str!("../../../scenes/heated-plate.json"),
    ),
    (
        "dam-water-level",
        include_str!("../../../scenes/dam-water-level.json"),
    ),
    ("hertz", include_str!("../../../scenes/hertz.json")),
    (
        "implant-impact",
        include_str!("../../../scenes/implant-impact.json"),
    ),
    (
        "hertz-nonmatching",
        include_str!("../../../scenes/hertz-nonmatching.json"),
    ),
    (
        "hip-replacement",
        include_str!("../../../scenes/hip-replacement.json"),
    ),
    ("knee", include_str!("../../../scenes/knee.json")),
    (
        "knee-cut-3",
        include_str!("../../../scenes/knee-cut-3.json"),
    ),
    (
        "knee-cut-5",
        include_str!("../../../scenes/knee-cut-5.json"),
    ),
    (
        "knee-cut-7",
        include_str!("../../../scenes/knee-cut-7.json"),
    ),
    ("knee-d05", include_str!("../../../scenes/knee-d05.json")),
    (
        "knee-mcs2007-coulomb",
        include_str!("../../../scenes/knee-mcs2007-coulomb.json"),
    ),
    (
        "knee-orthotropic-bone",
        include_str!("../../../scenes/knee-orthotropic-bone.json"),
    ),
    (
        "knee-sagittal",
        include_str!("../../../scenes/knee-sagittal.json"),
    ),
    (
        "loaded-block",
        include_str!("../../../scenes/loaded-block.json"),
    ),
    (
        "lower-limb-cartilage",
        include_str!("../../../scenes/lower-limb-cartilage.json"),
    ),
    (
        "thermo-contact-fault",
        include_str!("../../../scenes/thermo-contact-fault.json"),
    ),
    (
        "thick-cylinder",
        include_str!("../../../scenes/thick-cylinder.json"),
    ),
    (
        "tibia-marrow",
        include_str!("../../../scenes/tibia-marrow.json"),
    ),
    (
        "tunnel-fault",
        include_str!("../../../scenes/tunnel-fault.json"),
    ),
    (
        "tunnel-fault-nonmatching",
        include_str!("../../../scenes/tunnel-fault-nonmatching.json"),
    ),
    (
        "tunnel-fault-seismic",
        include_str!("../../../scenes/tunnel-fault-seismic.json"),
    ),
    (
        "tunnel-fault-slip-profile",
        include_str!("../../../scenes/tunnel-fault-slip-profile.json"),
    ),
    (
        "tunnel-layered-rock",
        include_str!("../../../scenes/tunnel-layered-rock.json"),
    ),
];

/// The JSON text of a bundled example.
pub fn example(name: &str) -> Option<&'static str> {
    EXAMPLES.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

/// The JSON text of a bundled example, or an error naming the unknown name.
pub fn find(name: &str) -> Result<&'static str, crate::error::WsmError> {
    example(name).ok_or_else(|| crate::error::WsmError::NotFound {
        what: "bundled example",
        name: name.to_string(),
    })
}

/// The names of the bundled examples.
pub fn names() -> impl Iterator<Item = &'static str> {
    EXAMPLES.iter().map(|(n, _)| *n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_example_parses_and_validates() {
        for (name, text) in EXAMPLES {
            if let Err(e) = crate::scene::parse(text) {
                panic!("example {name}: {e}");
            }
        }
    }
}
