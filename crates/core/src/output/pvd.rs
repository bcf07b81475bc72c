//! The ParaView data (.pvd) index of a series of VTU files (design §5.6): ParaView and PyVista
//! open the series in one go, one file per time step; step k is the k-th file (or the file at
//! its time, for a dynamic run's series), and an XML comment lists what each step holds.

use std::fmt::Write;

/// One file of the series: its name (relative to the index) and what it holds.
#[derive(Debug, Clone, PartialEq)]
pub struct SeriesEntry {
    /// The file's name, relative to the index's directory.
    pub file: String,
    /// What it holds, in words (`worst phi3`).
    pub title: String,
    /// Its time \[s\] (a dynamic run's output time); `None`: its index in the series.
    pub time: Option<f64>,
}

/// The .pvd document of `entries`, step k being entry k.
pub fn write_pvd(entries: &[SeriesEntry]) -> String {
    let mut s = String::from("<?xml version=\"1.0\"?>\n<!-- wsm scenarios, one per time step:\n");
    for (k, entry) in entries.iter().enumerate() {
        // "--" may not appear in an XML comment.
        let _ = writeln!(s, "     {k}: {}", entry.title.replace("--", "- -"));
    }
    s.push_str("-->\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n<Collection>\n");
    for (k, entry) in entries.iter().enumerate() {
        let step = entry
            .time
            .map_or_else(|| k.to_string(), |t| format!("{t:e}"));
        let _ = writeln!(
            s,
            "<DataSet timestep=\"{step}\" group=\"\" part=\"0\" file=\"{}\"/>",
            attribute(&entry.file)
        );
    }
    s.push_str("</Collection>\n</VTKFile>\n");
    s
}

fn attribute(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('"', "&quot;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_follow_the_entries() {
        let entries = [
            SeriesEntry {
                file: "nominal.vtu".into(),
                title: "nominal".into(),
                time: None,
            },
            SeriesEntry {
                file: "worst-phi3.vtu".into(),
                title: "worst phi3 -- roof".into(),
                time: None,
            },
        ];
        let text = write_pvd(&entries);
        assert!(
            text.contains("<DataSet timestep=\"0\" group=\"\" part=\"0\" file=\"nominal.vtu\"/>")
        );
        assert!(text
            .contains("<DataSet timestep=\"1\" group=\"\" part=\"0\" file=\"worst-phi3.vtu\"/>"));
        assert!(text.contains("1: worst phi3 - - roof"));
        let comment = &text[text.find("<!--").unwrap() + 4..text.find("-->").unwrap()];
        assert!(!comment.contains("--"));
    }
}
