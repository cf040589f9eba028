//! Vector export of a design for other toolchains (Inkscape, LightBurn, a plotter, a drag knife,
//! LibreCAD): each scratch one straight line at true size in millimetres, seen from above the
//! plate (+x to the right, +y up the page), grouped by depth band; the plate outline on its own.
//! An arc scratch is an SVG `<path>` with one `A` command and a DXF `ARC`, at true size.
//!
//! Bands: when commanded depths are known (the design's `z_mm` column, or the tool's curve),
//! scratches are grouped by commanded depth; otherwise by the groove's visible width
//! W = w sqrt(1 - exp(-2d/w)) (engine/docs/model.md section 2). With at most [`MAX_BANDS`] distinct values,
//! each value is a band of its own; otherwise the range is cut into [`MAX_BANDS`] equal bands and
//! empty ones are left out. A band's name says its number and value or range in micrometres
//! (`p` for a decimal point), e.g. `band2_depth_30um` or `band3_width_41p5-52um`.
//!
//! SVG: `width`/`height` in mm with a matching `viewBox` (1 user unit = 1 mm, origin at the plate's
//! top-left corner: SVG x = x + L/2, SVG y = L/2 - y); one `<g>` per band (an Inkscape layer, its
//! own stroke colour, so LightBurn sees one layer per band), each scratch a `<line id="sN">` whose
//! stroke width is the groove's visible width, with butt caps (the model's groove has no end
//! caps); the plate outline in `<g id="plate">`; the orientation mark that `plan` cuts at the
//! plate's +x edge (the set-up sheet's reference) in `<g id="mark_plus_x_edge">`.
//!
//! DXF: AutoCAD 2000 (AC1015) ASCII, the first version whose readers honour `$INSUNITS` (4: mm).
//! HEADER, CLASSES, TABLES (with one LAYER per band and `plate`), BLOCKS, ENTITIES (one LINE per
//! scratch on its band's layer, four LINEs of the plate outline on `plate`, the orientation mark
//! on `mark_plus_x_edge`), OBJECTS; plate
//! coordinates as they are (origin at the plate centre, +y up).
//!
//! Both are returned as text; the caller writes them (atomically).
use std::fmt::Write as _;

use scratchart_model::scene::Scene;

use crate::plan::{orientation_mark, Mark, MARK_CLEAR_MM};

/// The most bands a drawing is split into (a laser's or cutter's layer list stays short).
pub const MAX_BANDS: usize = 8;

/// What the bands group by.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BandBy {
    /// Commanded depth, mm.
    Depth,
    /// Visible width, mm.
    Width,
}

/// One band: its name and range (mm).
#[derive(Clone, Debug, PartialEq)]
pub struct Band {
    pub name: String,
    pub lo: f64,
    pub hi: f64,
}

/// One scratch as drawn: endpoints (plate coordinates, mm), visible width (mm), band index, and
/// its bulge (0: a line; else an arc, `scratchart_model::arc`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    pub a: [f64; 2],
    pub b: [f64; 2],
    pub width: f64,
    pub band: usize,
    pub bulge: f64,
}

/// A design ready to export.
#[derive(Clone, Debug, PartialEq)]
pub struct Drawing {
    pub plate_mm: f64,
    pub by: BandBy,
    pub bands: Vec<Band>,
    pub lines: Vec<Line>,
    /// The orientation mark at the plate's +x edge, placed as `plan` cuts it
    /// ([`orientation_mark`]); `None` to leave it out (as `plan --no-mark`).
    pub mark: Option<Mark>,
}

/// The layer (SVG group, DXF layer) of the orientation mark.
pub const MARK_LAYER: &str = "mark_plus_x_edge";

/// Visible width of a groove (engine/docs/model.md section 2), mm.
pub fn visible_width(w: f64, d: f64) -> f64 {
    w * (1.0 - (-2.0 * d / w).exp()).sqrt()
}

/// The drawing of `scene`, banded by `depths` (one commanded depth per scratch, mm) when given,
/// else by visible width.
pub fn drawing(scene: &Scene, depths: Option<&[f64]>) -> Result<Drawing, String> {
    let widths: Vec<f64> = scene.scratches.iter().map(|s| visible_width(s.w, s.d)).collect();
    let (by, q): (BandBy, Vec<f64>) = match depths {
        Some(z) => {
            if z.len() != scene.scratches.len() {
                return Err(format!("{} depths for {} scratches", z.len(), scene.scratches.len()));
            }
            (BandBy::Depth, z.to_vec())
        }
        None => (BandBy::Width, widths.clone()),
    };
    if let Some(k) = q.iter().position(|v| !v.is_finite()) {
        return Err(format!("scratch {}: its depth or width is not finite", k + 1));
    }
    let lo = q.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = q.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let mut distinct = q.clone();
    distinct.sort_by(f64::total_cmp);
    distinct.dedup();
    let what = match by {
        BandBy::Depth => "depth",
        BandBy::Width => "width",
    };
    let (bands, band_of): (Vec<Band>, Vec<usize>) = if distinct.len() <= MAX_BANDS {
        // One band per value.
        let bands = distinct
            .iter()
            .enumerate()
            .map(|(i, &v)| Band {
                name: format!("band{}_{what}_{}um", i + 1, um(v)),
                lo: v,
                hi: v,
            })
            .collect();
        let band_of = q
            .iter()
            .map(|v| distinct.iter().position(|x| x == v).expect("a listed value"))
            .collect();
        (bands, band_of)
    } else {
        // MAX_BANDS equal bands over the range; empty ones left out.
        let k = MAX_BANDS;
        let span = hi - lo;
        let index = |v: f64| (((v - lo) / span * k as f64).floor() as usize).min(k - 1);
        let mut renumber = vec![usize::MAX; k];
        let mut bands = Vec::new();
        for i in 0..k {
            if q.iter().any(|&v| index(v) == i) {
                let (blo, bhi) = (lo + span * i as f64 / k as f64, lo + span * (i + 1) as f64 / k as f64);
                renumber[i] = bands.len();
                bands.push(Band {
                    name: format!("band{}_{what}_{}-{}um", bands.len() + 1, um(blo), um(bhi)),
                    lo: blo,
                    hi: bhi,
                });
            }
        }
        let band_of = q.iter().map(|&v| renumber[index(v)]).collect();
        (bands, band_of)
    };
    let lines: Vec<Line> = scene
        .scratches
        .iter()
        .zip(&widths)
        .zip(band_of)
        .map(|((s, &w), band)| Line {
            a: s.p0,
            b: s.p1,
            width: w,
            band,
            bulge: s.bulge,
        })
        .collect();
    let mut sc: Vec<([f64; 2], [f64; 2], f64)> = Vec::with_capacity(lines.len());
    for l in &lines {
        let p = crate::plan::arc_points(l.a, l.b, l.bulge, 0.1);
        sc.extend(p.windows(2).map(|q| (q[0], q[1], l.width)));
    }
    let deepest = depths.map_or(0.0, |z| z.iter().cloned().fold(0.0f64, f64::max));
    let mark = Some(orientation_mark(&sc, scene.plate.size_mm, deepest, MARK_CLEAR_MM));
    Ok(Drawing {
        plate_mm: scene.plate.size_mm,
        by,
        bands,
        lines,
        mark,
    })
}

/// Micrometres for a band name: whole ones, or with one decimal when they have a fraction
/// (written with `p` for the point, which layer names may not hold everywhere).
fn um(mm: f64) -> String {
    let u = (mm * 1e4).round() / 10.0;
    if u.fract() == 0.0 {
        format!("{u:.0}")
    } else {
        format!("{u:.1}").replace('.', "p")
    }
}

/// A number with up to 9 decimals (1e-9 mm), no exponent, no trailing zeros, no negative zero.
fn n(x: f64) -> String {
    let s = format!("{x:.9}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" || s.is_empty() {
        "0".into()
    } else {
        s.to_string()
    }
}

/// Stroke colours of the bands (SVG) and their AutoCAD colour indices (DXF), in band order.
const COLOURS: [(&str, u8); MAX_BANDS] = [
    ("#0000ff", 5),
    ("#ff0000", 1),
    ("#00a000", 3),
    ("#c08000", 30),
    ("#00c0c0", 4),
    ("#ff00ff", 6),
    ("#808080", 8),
    ("#804000", 34),
];

/// The drawing as an SVG document.
pub fn svg(d: &Drawing) -> String {
    let l = d.plate_mm;
    let h = 0.5 * l;
    let mut s = String::new();
    let _ = writeln!(s, r#"<?xml version="1.0" encoding="UTF-8" standalone="no"?>"#);
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" version="1.1" width="{0}mm" height="{0}mm" viewBox="0 0 {0} {0}">"#,
        n(l)
    );
    let _ = writeln!(
        s,
        "<!-- scratchart export: {} scratches on a {} mm plate seen from above; 1 unit = 1 mm; \
         plate x = svg x - {h}, plate y = {h} - svg y; stroke width = visible groove width -->",
        d.lines.len(),
        n(l),
        h = n(h)
    );
    let _ = writeln!(
        s,
        r##"<g id="plate" inkscape:groupmode="layer" inkscape:label="plate"><rect x="0" y="0" width="{0}" height="{0}" fill="none" stroke="#000000" stroke-width="0.1"/></g>"##,
        n(l)
    );
    for (bi, b) in d.bands.iter().enumerate() {
        let _ = writeln!(
            s,
            r#"<g id="{0}" inkscape:groupmode="layer" inkscape:label="{0}" fill="none" stroke="{1}" stroke-linecap="butt">"#,
            b.name,
            COLOURS[bi % MAX_BANDS].0
        );
        for (k, ln) in d.lines.iter().enumerate().filter(|(_, ln)| ln.band == bi) {
            if let Some(g) = scratchart_model::arc::ArcGeom::of(ln.a, ln.b, ln.bulge) {
                // SVG's y runs down the page: a counter-clockwise arc on the plate is drawn with
                // the sweep flag 0 (the negative-angle direction there).
                let _ = writeln!(
                    s,
                    r#"<path id="s{}" d="M {} {} A {r} {r} 0 {} {} {} {}" stroke-width="{}"/>"#,
                    k + 1,
                    n(ln.a[0] + h),
                    n(h - ln.a[1]),
                    u8::from(ln.bulge.abs() > 1.0),
                    u8::from(ln.bulge < 0.0),
                    n(ln.b[0] + h),
                    n(h - ln.b[1]),
                    n(ln.width),
                    r = n(g.radius)
                );
                continue;
            }
            let _ = writeln!(
                s,
                r#"<line id="s{}" x1="{}" y1="{}" x2="{}" y2="{}" stroke-width="{}"/>"#,
                k + 1,
                n(ln.a[0] + h),
                n(h - ln.a[1]),
                n(ln.b[0] + h),
                n(h - ln.b[1]),
                n(ln.width)
            );
        }
        let _ = writeln!(s, "</g>");
    }
    if let Some(mk) = &d.mark {
        // As `plan` cuts it: one line pointing +x near the +x edge (the set-up sheet's reference).
        let width = d.lines.iter().map(|l| l.width).fold(0.05f64, f64::max);
        let _ = writeln!(
            s,
            r##"<g id="{MARK_LAYER}" inkscape:groupmode="layer" inkscape:label="{MARK_LAYER}" fill="none" stroke="#000000" stroke-linecap="butt"><line id="mark" x1="{}" y1="{}" x2="{}" y2="{}" stroke-width="{}"/></g>"##,
            n(mk.a[0] + h),
            n(h - mk.a[1]),
            n(mk.b[0] + h),
            n(h - mk.b[1]),
            n(width)
        );
    }
    let _ = writeln!(s, "</svg>");
    s
}

/// DXF text: group code and value pairs, one per line.
struct Dxf {
    s: String,
    handle: u32,
}

impl Dxf {
    fn pair(&mut self, code: i32, value: impl std::fmt::Display) {
        let _ = write!(self.s, "{code:>3}\n{value}\n");
    }
    fn pairs(&mut self, list: &[(i32, &str)]) {
        for (c, v) in list {
            self.pair(*c, v);
        }
    }
    /// A new handle (hex).
    fn h(&mut self) -> String {
        self.handle += 1;
        format!("{:X}", self.handle)
    }
    fn table(&mut self, name: &str, entries: usize) -> String {
        let h = self.h();
        self.pairs(&[(0, "TABLE"), (2, name), (5, &h), (330, "0"), (100, "AcDbSymbolTable")]);
        self.pair(70, entries);
        h
    }
    fn record(&mut self, kind: &str, owner: &str, subclass: &str) -> String {
        let h = self.h();
        self.pairs(&[
            (0, kind),
            (5, &h),
            (330, owner),
            (100, "AcDbSymbolTableRecord"),
            (100, subclass),
        ]);
        h
    }
}

/// The drawing as a DXF (AC1015) document: the tables, blocks, entities and objects first (they
/// take the handles), the header last (it needs `$HANDSEED`).
pub fn dxf(d: &Drawing) -> String {
    let h = 0.5 * d.plate_mm;
    let mut body = Dxf {
        s: String::new(),
        handle: 0x1F,
    };
    let ms = dxf_tables(&mut body, d);
    dxf_entities(&mut body, d, &ms);
    dxf_objects(&mut body);
    let seed = format!("{:X}", body.handle + 1);
    let mut x = Dxf {
        s: String::new(),
        handle: 0x1F,
    };
    x.pairs(&[
        (
            999,
            "scratchart export: scratches as LINEs on one layer per band, the plate outline on layer plate",
        ),
        (0, "SECTION"),
        (2, "HEADER"),
        (9, "$ACADVER"),
        (1, "AC1015"),
        (9, "$HANDSEED"),
        (5, &seed),
        (9, "$INSUNITS"),
        (70, "4"),
        (9, "$MEASUREMENT"),
        (70, "1"),
        (9, "$EXTMIN"),
        (10, &n(-h)),
        (20, &n(-h)),
        (30, "0"),
        (9, "$EXTMAX"),
        (10, &n(h)),
        (20, &n(h)),
        (30, "0"),
        (0, "ENDSEC"),
    ]);
    x.s + &body.s
}

/// The CLASSES, TABLES and BLOCKS sections (one layer per band, the plate's layer, the model and
/// paper spaces); the model space's handle.
fn dxf_tables(b: &mut Dxf, d: &Drawing) -> String {
    b.pairs(&[(0, "SECTION"), (2, "CLASSES"), (0, "ENDSEC")]);
    b.pairs(&[(0, "SECTION"), (2, "TABLES")]);
    b.table("VPORT", 0);
    b.pair(0, "ENDTAB");
    let lt = b.table("LTYPE", 3);
    for (name, text) in [("ByBlock", ""), ("ByLayer", ""), ("Continuous", "Solid line")] {
        b.record("LTYPE", &lt, "AcDbLinetypeTableRecord");
        b.pairs(&[(2, name), (70, "0"), (3, text), (72, "65"), (73, "0"), (40, "0.0")]);
    }
    b.pair(0, "ENDTAB");
    let layers: Vec<(String, u8)> = std::iter::once(("0".to_string(), 7))
        .chain(std::iter::once(("plate".to_string(), 7)))
        .chain(
            d.bands
                .iter()
                .enumerate()
                .map(|(i, band)| (band.name.clone(), COLOURS[i % MAX_BANDS].1)),
        )
        .chain(d.mark.is_some().then(|| (MARK_LAYER.to_string(), 7)))
        .collect();
    let la = b.table("LAYER", layers.len());
    for (name, colour) in &layers {
        b.record("LAYER", &la, "AcDbLayerTableRecord");
        b.pair(2, name);
        b.pair(70, 0);
        b.pair(62, colour);
        b.pair(6, "Continuous");
    }
    b.pair(0, "ENDTAB");
    let st = b.table("STYLE", 1);
    b.record("STYLE", &st, "AcDbTextStyleTableRecord");
    b.pairs(&[
        (2, "Standard"),
        (70, "0"),
        (40, "0.0"),
        (41, "1.0"),
        (50, "0.0"),
        (71, "0"),
        (42, "2.5"),
        (3, "txt"),
        (4, ""),
    ]);
    b.pair(0, "ENDTAB");
    for t in ["VIEW", "UCS"] {
        b.table(t, 0);
        b.pair(0, "ENDTAB");
    }
    let ap = b.table("APPID", 1);
    b.record("APPID", &ap, "AcDbRegAppTableRecord");
    b.pairs(&[(2, "ACAD"), (70, "0"), (0, "ENDTAB")]);
    b.table("DIMSTYLE", 0);
    b.pairs(&[(100, "AcDbDimStyleTable"), (0, "ENDTAB")]);
    let br = b.table("BLOCK_RECORD", 2);
    let ms = b.record("BLOCK_RECORD", &br, "AcDbBlockTableRecord");
    b.pair(2, "*Model_Space");
    let ps = b.record("BLOCK_RECORD", &br, "AcDbBlockTableRecord");
    b.pair(2, "*Paper_Space");
    b.pairs(&[(0, "ENDTAB"), (0, "ENDSEC")]);
    dxf_blocks(b, &ms, &ps);
    ms
}

/// The BLOCKS section: the model and paper spaces' blocks.
fn dxf_blocks(b: &mut Dxf, ms: &str, ps: &str) {
    b.pairs(&[(0, "SECTION"), (2, "BLOCKS")]);
    for (name, owner, paper) in [("*Model_Space", ms, false), ("*Paper_Space", ps, true)] {
        let hb = b.h();
        b.pairs(&[(0, "BLOCK"), (5, &hb), (330, owner), (100, "AcDbEntity")]);
        if paper {
            b.pair(67, 1);
        }
        b.pairs(&[
            (8, "0"),
            (100, "AcDbBlockBegin"),
            (2, name),
            (70, "0"),
            (10, "0.0"),
            (20, "0.0"),
            (30, "0.0"),
            (3, name),
            (1, ""),
        ]);
        let he = b.h();
        b.pairs(&[(0, "ENDBLK"), (5, &he), (330, owner), (100, "AcDbEntity")]);
        if paper {
            b.pair(67, 1);
        }
        b.pairs(&[(8, "0"), (100, "AcDbBlockEnd")]);
    }
    b.pair(0, "ENDSEC");
}

/// The ENTITIES section: the plate's outline and every scratch, as LINEs in model space `ms`.
fn dxf_entities(b: &mut Dxf, d: &Drawing, ms: &str) {
    let h = 0.5 * d.plate_mm;
    b.pairs(&[(0, "SECTION"), (2, "ENTITIES")]);
    let line = |b: &mut Dxf, layer: &str, p: [f64; 2], q: [f64; 2]| {
        let hl = b.h();
        b.pairs(&[
            (0, "LINE"),
            (5, &hl),
            (330, ms),
            (100, "AcDbEntity"),
            (8, layer),
            (100, "AcDbLine"),
        ]);
        b.pairs(&[
            (10, &n(p[0])),
            (20, &n(p[1])),
            (30, "0"),
            (11, &n(q[0])),
            (21, &n(q[1])),
            (31, "0"),
        ]);
    };
    for (p, q) in [
        ([-h, -h], [h, -h]),
        ([h, -h], [h, h]),
        ([h, h], [-h, h]),
        ([-h, h], [-h, -h]),
    ] {
        line(b, "plate", p, q);
    }
    for ln in &d.lines {
        match scratchart_model::arc::ArcGeom::of(ln.a, ln.b, ln.bulge) {
            None => line(b, &d.bands[ln.band].name, ln.a, ln.b),
            Some(g) => dxf_arc(b, ms, &d.bands[ln.band].name, ln, &g),
        }
    }
    if let Some(mk) = &d.mark {
        line(b, MARK_LAYER, mk.a, mk.b);
    }
    b.pair(0, "ENDSEC");
}

/// An arc scratch as a DXF ARC: centre, radius, and the start and end angles (degrees) of its
/// counter-clockwise sweep (a clockwise arc from a to b runs counter-clockwise from b to a).
fn dxf_arc(b: &mut Dxf, ms: &str, layer: &str, ln: &Line, g: &scratchart_model::arc::ArcGeom) {
    let ang = |p: [f64; 2]| {
        (p[1] - g.centre[1])
            .atan2(p[0] - g.centre[0])
            .to_degrees()
            .rem_euclid(360.0)
    };
    let (start, end) = if ln.bulge > 0.0 {
        (ang(ln.a), ang(ln.b))
    } else {
        (ang(ln.b), ang(ln.a))
    };
    let ha = b.h();
    b.pairs(&[
        (0, "ARC"),
        (5, &ha),
        (330, ms),
        (100, "AcDbEntity"),
        (8, layer),
        (100, "AcDbCircle"),
    ]);
    b.pairs(&[
        (10, &n(g.centre[0])),
        (20, &n(g.centre[1])),
        (30, "0"),
        (40, &n(g.radius)),
        (100, "AcDbArc"),
        (50, &n(start)),
        (51, &n(end)),
    ]);
}

/// The OBJECTS section: the root dictionary and its group dictionary.
fn dxf_objects(b: &mut Dxf) {
    let (root, group) = (b.h(), b.h());
    b.pairs(&[(0, "SECTION"), (2, "OBJECTS")]);
    b.pairs(&[
        (0, "DICTIONARY"),
        (5, &root),
        (330, "0"),
        (100, "AcDbDictionary"),
        (281, "1"),
        (3, "ACAD_GROUP"),
        (350, &group),
    ]);
    b.pairs(&[
        (0, "DICTIONARY"),
        (5, &group),
        (330, &root),
        (100, "AcDbDictionary"),
        (281, "1"),
    ]);
    b.pairs(&[(0, "ENDSEC"), (0, "EOF")]);
}
