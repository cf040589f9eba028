//! The scratch CSV file (MODEL.md section 6): header `x0,y0,x1,y1,w,d,alpha`, one scratch per
//! row, numbers in millimetres.

use std::path::Path;

use super::{invalid, SceneError, Scratch, COLS, CSV_HEADER};

/// Read a scratch CSV (header `x0,y0,x1,y1,w,d,alpha`; blank lines and `#` comments skipped).
/// Checks the syntax and that every number is finite; MODEL.md's range checks against the plate
/// are done by [`Scene::load`](super::Scene::load) / [`Scene::validate`](super::Scene::validate),
/// which know the plate.
pub fn read_scratches_csv(path: &Path) -> Result<Vec<Scratch>, SceneError> {
    let list = read_scratches_csv_lines(path)?;
    Ok(list.into_iter().map(|(s, _)| s).collect())
}

/// As [`read_scratches_csv`], with each scratch's 1-based line number.
pub fn read_scratches_csv_lines(path: &Path) -> Result<Vec<(Scratch, usize)>, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
        what: "scratch CSV file",
        path: path.to_path_buf(),
        cause: source,
    })?;
    let file = path.display().to_string();
    // Spreadsheets often write a UTF-8 byte-order mark first: it is not part of the header.
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let mut out = Vec::new();
    let mut header_seen = false;
    let mut row = 0usize;
    for (ln, raw) in text.lines().enumerate() {
        let line_no = ln + 1;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(|c| c.trim()).collect();
        let numeric = cells.iter().all(|c| c.parse::<f64>().is_ok());
        if !header_seen && out.is_empty() && !numeric {
            header_seen = true;
            let norm: Vec<String> = cells.iter().map(|c| c.to_ascii_lowercase()).collect();
            if norm != COLS {
                return Err(invalid(
                    &file,
                    format!("header (line {line_no})"),
                    format!("found `{line}`, expected `{CSV_HEADER}`"),
                ));
            }
            continue;
        }
        row += 1;
        let err = |msg: String| SceneError::Csv {
            file: file.clone(),
            row,
            line: line_no,
            msg,
        };
        if cells.len() != 7 {
            return Err(err(format!("found {} columns, expected 7 ({CSV_HEADER})", cells.len())));
        }
        let mut r = [0.0; 7];
        for (c, cell) in cells.iter().enumerate() {
            let x: f64 = cell
                .parse()
                .map_err(|_| err(format!("column {} `{cell}` is not a number", COLS[c])))?;
            if !x.is_finite() {
                return Err(err(format!(
                    "column {} `{cell}` is not a finite number (NaN and infinity are not allowed)",
                    COLS[c]
                )));
            }
            r[c] = x;
        }
        out.push((Scratch::from_row(r), line_no));
    }
    Ok(out)
}

/// The CSV text of `scratches`: the header, then one row per scratch with every number in
/// shortest round-trip form, so reading it back gives exactly the same values.
pub(super) fn scratches_csv_text(scratches: &[Scratch]) -> String {
    let mut csv = String::with_capacity(32 + scratches.len() * 80);
    csv.push_str(CSV_HEADER);
    csv.push('\n');
    for s in scratches {
        let r = s.to_row();
        let cells: Vec<String> = r.iter().map(|x| format!("{x}")).collect();
        csv.push_str(&cells.join(","));
        csv.push('\n');
    }
    csv
}
