//! Report files: Table 1 (`table1.md`, `.csv`, `.json`) and the error against run time
//! (`runtime.md`, `.csv`, `.svg`). Every Markdown table goes through [`MarkdownTable`] and
//! every CSV file through the `csv` crate.

use std::path::Path;

use serde::Serialize;

use super::plot::runtime_svg;
use super::runtime::CurvePoint;
use super::table1::{Row, RISE_FRAME};
use crate::error::TrainError;

/// A Markdown table: a header row and rows of cells; the first `left` columns are
/// left-aligned, the rest (numbers) right-aligned.
#[derive(Debug, Clone)]
pub struct MarkdownTable {
    headers: Vec<String>,
    left: usize,
    rows: Vec<Vec<String>>,
}

impl MarkdownTable {
    /// An empty table with these column headers.
    pub fn new<S: AsRef<str>>(headers: &[S], left: usize) -> Self {
        Self { headers: headers.iter().map(|h| h.as_ref().to_string()).collect(), left, rows: Vec::new() }
    }

    /// Appends a row (missing cells are left empty, extra ones dropped).
    pub fn push(&mut self, cells: Vec<String>) {
        self.rows.push(cells);
    }

    /// The table as Markdown text, one line per row; `|` inside cells is escaped.
    pub fn render(&self) -> String {
        let line = |cells: &[String]| {
            let cells: Vec<String> = (0..self.headers.len())
                .map(|i| cells.get(i).map_or(String::new(), |c| c.replace('|', "\\|")))
                .collect();
            format!("| {} |\n", cells.join(" | "))
        };
        let rule: Vec<&str> = (0..self.headers.len()).map(|i| if i < self.left { "---" } else { "---:" }).collect();
        let mut s = line(&self.headers);
        s += &format!("|{}|\n", rule.join("|"));
        for r in &self.rows {
            s += &line(r);
        }
        s
    }
}

fn write_text(path: &Path, text: &str) -> Result<(), TrainError> {
    std::fs::write(path, text).map_err(|e| TrainError::io(path, e))
}

/// Writes `records` as CSV with a header row from their field names.
pub fn write_csv<T: Serialize>(path: &Path, records: &[T]) -> Result<(), TrainError> {
    let mut w = csv::Writer::from_path(path).map_err(|e| TrainError::io(path, e))?;
    for r in records {
        w.serialize(r).map_err(|e| TrainError::io(path, e))?;
    }
    w.flush().map_err(|e| TrainError::io(path, e))
}

/// Table 1 as Markdown (the columns of the paper's Table 1, then body penetration, the
/// distance from the skinned garment, the rise, the area growth, the strain and the speed).
pub fn table1_markdown(rows: &[Row]) -> String {
    let rise = format!("rise after {RISE_FRAME} frames (cm)");
    let mut t = MarkdownTable::new(
        &[
            "method",
            "garment",
            "motion",
            "frames",
            "V (cm³)",
            "L_self-col (×10⁻³)",
            "% > 0.1",
            "% > 0.01",
            "body pen. (%)",
            "from skinned (cm)",
            rise.as_str(),
            "area growth (%)",
            "strain (%)",
            "FPS",
        ],
        3,
    );
    for r in rows {
        t.push(vec![
            r.method.clone(),
            r.garment.clone(),
            r.motion.clone(),
            r.frames.to_string(),
            format!("{:.3}", r.volume_cm3),
            format!("{:.3}", r.l_selfcol * 1e3),
            format!("{:.1}", r.pct_above_0_1),
            format!("{:.1}", r.pct_above_0_01),
            format!("{:.2}", r.body_penetration_pct),
            format!("{:.1}", r.departure_cm),
            r.rise_30_cm.map_or("–".into(), |v| format!("{v:.1}")),
            format!("{:.1}", r.area_growth_pct),
            format!("{:.1}", r.strain_pct),
            format!("{:.1}", r.fps),
        ]);
    }
    t.render()
}

/// Writes `table1.md`, `table1.csv`, `table1.json`, `runtime.md`, `runtime.csv` and
/// `runtime.svg` into `out`. `command` is recorded in the Markdown files.
pub fn write_reports(out: &Path, rows: &[Row], curve: &[CurvePoint], command: &str) -> Result<(), TrainError> {
    std::fs::create_dir_all(out).map_err(|e| TrainError::io(out, e))?;
    let md = format!(
        "# Table 1: self-collision on the test motions\n\nProduced by `{command}`.\n\n{}",
        table1_markdown(rows)
    );
    write_text(&out.join("table1.md"), &md)?;
    write_csv(&out.join("table1.csv"), rows)?;
    let json_path = out.join("table1.json");
    let json = serde_json::to_string_pretty(rows).map_err(|e| TrainError::io(&json_path, e))?;
    write_text(&json_path, &json)?;

    let mut t = MarkdownTable::new(&["method", "garment", "ms/frame", "energy gap (J)", "V (cm³)"], 2);
    for p in curve {
        t.push(vec![
            p.method.clone(),
            p.garment.clone(),
            format!("{:.2}", p.ms_per_frame),
            format!("{:.4e}", p.energy_gap),
            format!("{:.3}", p.volume_cm3),
        ]);
    }
    let md = format!(
        "# Error against run time\n\nProduced by `{command}`. Energy gap = E(answer) − E(reference solver, \
         converged), J, averaged over test states of the network's rollout (negative: the answer ends below the \
         converged reference). \"network + N it\": N Newton iterations of the same solver started from the \
         network's answer.\n\n{}\n![error against run time](runtime.svg)\n",
        t.render()
    );
    write_text(&out.join("runtime.md"), &md)?;
    write_csv(&out.join("runtime.csv"), curve)?;
    write_text(&out.join("runtime.svg"), &runtime_svg(curve)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_tables_align_numbers_right_and_escape_bars() {
        let mut t = MarkdownTable::new(&["name", "value"], 1);
        t.push(vec!["a|b".into(), "1.5".into()]);
        t.push(vec!["short".into()]);
        assert_eq!(t.render(), "| name | value |\n|---|---:|\n| a\\|b | 1.5 |\n| short |  |\n");
    }
}
