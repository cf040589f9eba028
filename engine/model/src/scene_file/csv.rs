//! The scratch CSV file (engine/docs/model.md section 6): header `x0,y0,x1,y1,w,d,alpha`, one scratch per
//! row, numbers in millimetres.
//!
//! Extra named columns may follow the seven (for example `z_mm`, the commanded carve depth that
//! `scratchart design --tool` writes). They need the header to name them, hold finite numbers,
//! and are kept: [`read_scratches_csv_table`] returns them as an [`Extra`], and
//! [`Scene::save_extra`](crate::scene::Scene::save_extra) writes them back. Readers that only need the
//! seven ([`read_scratches_csv`], [`Scene::load`](crate::scene::Scene::load)) accept and skip them.
//!
//! One named column is the scratches' own: `bulge`, an arc's (crate::arc; 0 for a straight
//! scratch). It is read into [`Scratch::bulge`](crate::scene::Scratch) (not kept as an extra)
//! and written, right after the seven, whenever a scratch is an arc.

use std::path::Path;

use crate::scene::{invalid, SceneError, Scratch, BULGE_COL, COLS, CSV_HEADER};

/// Read a scratch CSV (header `x0,y0,x1,y1,w,d,alpha`; blank lines and `#` comments skipped).
/// Checks the syntax and that every number is finite; engine/docs/model.md's range checks against the plate
/// are done by [`Scene::load`](crate::scene::Scene::load) / [`Scene::validate`](crate::scene::Scene::validate),
/// which know the plate.
pub fn read_scratches_csv(path: &Path) -> Result<Vec<Scratch>, SceneError> {
    let list = read_scratches_csv_lines(path)?;
    Ok(list.into_iter().map(|(s, _)| s).collect())
}

/// Extra named columns of a scratch CSV, after the seven of engine/docs/model.md: `rows[k]` belongs to
/// scratch k and has one value per name.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Extra {
    pub names: Vec<String>,
    pub rows: Vec<Vec<f64>>,
}

impl Extra {
    /// The values of column `name`, one per scratch, if the file has it.
    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        let c = self.names.iter().position(|n| n == name)?;
        Some(self.rows.iter().map(|r| r[c]).collect())
    }

    /// Adds or replaces column `name` (one value per scratch).
    pub fn set_column(&mut self, name: &str, values: &[f64]) {
        let c = match self.names.iter().position(|n| n == name) {
            Some(c) => c,
            None => {
                self.names.push(name.to_string());
                for r in &mut self.rows {
                    r.push(0.0);
                }
                self.names.len() - 1
            }
        };
        if self.rows.len() < values.len() {
            self.rows.resize(values.len(), vec![0.0; self.names.len()]);
        }
        for (r, &v) in self.rows.iter_mut().zip(values) {
            r[c] = v;
        }
    }

    /// Keeps the rows of the scratches in `keep` (indices into the old list, in the new order).
    pub fn select(&self, keep: &[usize]) -> Extra {
        Extra {
            names: self.names.clone(),
            rows: if self.names.is_empty() {
                Vec::new()
            } else {
                keep.iter().map(|&k| self.rows[k].clone()).collect()
            },
        }
    }
}

/// As [`read_scratches_csv`], with each scratch's 1-based line number.
pub fn read_scratches_csv_lines(path: &Path) -> Result<Vec<(Scratch, usize)>, SceneError> {
    Ok(read_scratches_csv_table(path)?.0)
}

/// As [`read_scratches_csv_lines`], also returning the extra named columns after the seven.
pub fn read_scratches_csv_table(path: &Path) -> Result<(Vec<(Scratch, usize)>, Extra), SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
        what: "scratch CSV file",
        path: path.to_path_buf(),
        cause: source,
    })?;
    let file = path.display().to_string();
    // Spreadsheets often write a UTF-8 byte-order mark first: it is not part of the header.
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let mut out = Vec::new();
    let mut extra = Extra::default();
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
            if norm.len() < COLS.len() || norm[..COLS.len()] != COLS {
                return Err(invalid(
                    &file,
                    format!("header (line {line_no})"),
                    format!("found `{line}`, expected `{CSV_HEADER}` (extra named columns may follow the seven)"),
                ));
            }
            for name in &cells[COLS.len()..] {
                let ok = !name.is_empty()
                    && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
                    && !COLS.contains(&name.to_ascii_lowercase().as_str())
                    && !extra.names.iter().any(|n| n == name);
                if !ok {
                    return Err(invalid(
                        &file,
                        format!("header (line {line_no})"),
                        format!("extra column name `{name}` must be a new, non-empty name of letters, digits and `_`"),
                    ));
                }
                extra.names.push(name.to_string());
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
        let ncols = 7 + extra.names.len();
        if cells.len() != ncols {
            let hint = if cells.len() > 7 && !header_seen {
                " (extra columns after the seven need a header line that names them)".to_string()
            } else if extra.names.is_empty() {
                format!(" ({CSV_HEADER})")
            } else {
                format!(" ({CSV_HEADER},{})", extra.names.join(","))
            };
            return Err(err(format!("found {} columns, expected {ncols}{hint}", cells.len())));
        }
        let mut r = [0.0; 7];
        let mut ex = Vec::with_capacity(extra.names.len());
        for (c, cell) in cells.iter().enumerate() {
            let name = if c < 7 { COLS[c] } else { extra.names[c - 7].as_str() };
            let x: f64 = cell
                .parse()
                .map_err(|_| err(format!("column {name} `{cell}` is not a number")))?;
            if !x.is_finite() {
                return Err(err(format!(
                    "column {name} `{cell}` is not a finite number (NaN and infinity are not allowed)"
                )));
            }
            if c < 7 {
                r[c] = x;
            } else {
                ex.push(x);
            }
        }
        if !extra.names.is_empty() {
            extra.rows.push(ex);
        }
        out.push((Scratch::from_row(r), line_no));
    }
    take_bulge(&mut out, &mut extra);
    Ok((out, extra))
}

/// The `bulge` column (an arc's, crate::arc) is the scratches' own, not an extra one.
fn take_bulge(out: &mut [(Scratch, usize)], extra: &mut Extra) {
    let Some(c) = extra.names.iter().position(|n| n.eq_ignore_ascii_case(BULGE_COL)) else {
        return;
    };
    extra.names.remove(c);
    for (k, (s, _)) in out.iter_mut().enumerate() {
        s.bulge = extra.rows[k].remove(c);
    }
    if extra.names.is_empty() {
        extra.rows.clear();
    }
}

/// The CSV text of `scratches`: the header, then one row per scratch with every number in
/// shortest round-trip form, so reading it back gives exactly the same values.
pub(super) fn scratches_csv_text(scratches: &[Scratch], extra: &Extra) -> String {
    let mut csv = String::with_capacity(32 + scratches.len() * 80);
    csv.push_str(CSV_HEADER);
    let arcs = scratches.iter().any(Scratch::is_arc);
    if arcs {
        csv.push(',');
        csv.push_str(BULGE_COL);
    }
    for n in extra.names.iter().filter(|n| !n.eq_ignore_ascii_case(BULGE_COL)) {
        csv.push(',');
        csv.push_str(n);
    }
    csv.push('\n');
    for (k, s) in scratches.iter().enumerate() {
        let r = s.to_row();
        let mut cells: Vec<String> = r.iter().map(|x| format!("{x}")).collect();
        if arcs {
            cells.push(format!("{}", s.bulge));
        }
        if let Some(ex) = extra.rows.get(k) {
            let kept = extra
                .names
                .iter()
                .zip(ex)
                .filter(|(n, _)| !n.eq_ignore_ascii_case(BULGE_COL));
            cells.extend(kept.map(|(_, x)| format!("{x}")));
        }
        csv.push_str(&cells.join(","));
        csv.push('\n');
    }
    csv
}
