//! The vector export read back by independent parsers (roxmltree for SVG, the `dxf` crate for
//! DXF) and compared with the design endpoint by endpoint.
use scratchart_machine::export::{drawing, dxf, svg, visible_width, BandBy, Drawing, MARK_LAYER, MAX_BANDS};
use scratchart_machine::plan::{orientation_mark, Mark, MARK_CLEAR_MM};
use scratchart_model::scene::{Scene, Scratch};

const TOL: f64 = 1e-6;

struct Xs(u64);
impl Xs {
    fn f(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn design(n: usize, plate: f64) -> Scene {
    let mut r = Xs(0x2545_F491_4F6C_DD1D);
    let h = 0.45 * plate;
    let scratches = (0..n)
        .map(|_| {
            let a = [(2.0 * r.f() - 1.0) * h, (2.0 * r.f() - 1.0) * h];
            let t = r.f() * std::f64::consts::TAU;
            let l = 0.5 + 3.0 * r.f();
            Scratch {
                p0: a,
                p1: [(a[0] + l * t.cos()).clamp(-h, h), (a[1] + l * t.sin()).clamp(-h, h)],
                w: 0.03 + 0.1 * r.f(),
                d: 0.005 + 0.05 * r.f(),
                alpha: 0.1,
                bulge: 0.0,
            }
        })
        .collect();
    Scene::bare(plate, scratches)
}

fn close(a: [f64; 2], b: [f64; 2]) -> bool {
    (a[0] - b[0]).abs() <= TOL && (a[1] - b[1]).abs() <= TOL
}

/// Every scratch's band holds its value, and bands are at most MAX_BANDS.
fn bands_hold(d: &Drawing, values: &[f64]) {
    assert!(!d.bands.is_empty() && d.bands.len() <= MAX_BANDS);
    for (ln, v) in d.lines.iter().zip(values) {
        let b = &d.bands[ln.band];
        assert!(*v >= b.lo - 1e-12 && *v <= b.hi + 1e-12, "{v} outside {b:?}");
    }
}

/// The mark as `plan` places it for this design.
fn plan_mark(scene: &Scene, d: &Drawing) -> Mark {
    let sc: Vec<_> = scene
        .scratches
        .iter()
        .map(|s| (s.p0, s.p1, visible_width(s.w, s.d)))
        .collect();
    let deepest = match d.by {
        BandBy::Depth => d.bands.iter().map(|b| b.hi).fold(0.0, f64::max),
        BandBy::Width => 0.0,
    };
    orientation_mark(&sc, scene.plate.size_mm, deepest, MARK_CLEAR_MM)
}

fn check_svg(scene: &Scene, d: &Drawing) {
    let text = svg(d);
    let doc = roxmltree::Document::parse(&text).expect("the SVG parses");
    let root = doc.root_element();
    assert_eq!(root.tag_name().name(), "svg");
    let l = scene.plate.size_mm;
    assert_eq!(root.attribute("width"), Some(format!("{l}mm").as_str()));
    assert_eq!(root.attribute("height"), Some(format!("{l}mm").as_str()));
    let vb: Vec<f64> = root
        .attribute("viewBox")
        .unwrap()
        .split_whitespace()
        .map(|s| s.parse().unwrap())
        .collect();
    assert_eq!(vb, vec![0.0, 0.0, l, l], "1 user unit = 1 mm");
    let num = |n: roxmltree::Node, a: &str| -> f64 { n.attribute(a).unwrap().parse().unwrap() };
    // The plate outline in its own group.
    let plate = root
        .children()
        .find(|n| n.attribute("id") == Some("plate"))
        .expect("a plate group");
    let rect = plate.children().find(|n| n.has_tag_name("rect")).unwrap();
    assert_eq!((num(rect, "width"), num(rect, "height")), (l, l));
    assert_eq!(plate.descendants().filter(|n| n.has_tag_name("line")).count(), 0);
    // The orientation mark in its own group, where `plan` cuts it, pointing +x.
    let mk = d.mark.expect("the drawing has the +x mark");
    let group = root
        .children()
        .find(|n| n.attribute("id") == Some(MARK_LAYER))
        .expect("a mark group");
    let line = group.children().find(|n| n.has_tag_name("line")).unwrap();
    let back = |x: f64, y: f64| [x - 0.5 * l, 0.5 * l - y];
    let (a, b) = (
        back(num(line, "x1"), num(line, "y1")),
        back(num(line, "x2"), num(line, "y2")),
    );
    assert!(
        close(a, mk.a) && close(b, mk.b) && b[0] > a[0] && b[0] > 0.4 * l,
        "{a:?} {b:?}"
    );
    assert_eq!(mk, plan_mark(scene, d), "placed by plan's rule");
    // Every scratch once, in the group of its band, endpoints and width as designed.
    let mut seen = vec![false; scene.scratches.len()];
    for line in root
        .descendants()
        .filter(|n| n.has_tag_name("line") && n.attribute("id") != Some("mark"))
    {
        let k: usize = line.attribute("id").unwrap()[1..].parse::<usize>().unwrap() - 1;
        assert!(!seen[k], "scratch {} twice", k + 1);
        seen[k] = true;
        let s = &scene.scratches[k];
        let back = |x: f64, y: f64| [x - 0.5 * l, 0.5 * l - y];
        let p0 = back(num(line, "x1"), num(line, "y1"));
        let p1 = back(num(line, "x2"), num(line, "y2"));
        assert!(
            close(p0, s.p0) && close(p1, s.p1),
            "scratch {}: {p0:?} {p1:?} vs {s:?}",
            k + 1
        );
        assert!((num(line, "stroke-width") - visible_width(s.w, s.d)).abs() <= TOL);
        let group = line.parent().unwrap();
        assert_eq!(group.attribute("id"), Some(d.bands[d.lines[k].band].name.as_str()));
        assert_eq!(group.attribute("stroke-linecap"), Some("butt"));
    }
    assert!(seen.iter().all(|s| *s), "every scratch is drawn");
}

fn check_dxf(scene: &Scene, d: &Drawing, tag: &str) {
    let path = std::env::temp_dir().join(format!("scratchart_export_{}_{tag}.dxf", std::process::id()));
    std::fs::write(&path, dxf(d)).unwrap();
    let back = dxf::Drawing::load_file(&path).expect("the DXF parses");
    let _ = std::fs::remove_file(&path);
    assert_eq!(back.header.version, dxf::enums::AcadVersion::R2000);
    assert_eq!(back.header.default_drawing_units, dxf::enums::Units::Millimeters);
    let layers: Vec<String> = back.layers().map(|l| l.name.clone()).collect();
    assert!(layers.contains(&"plate".to_string()), "{layers:?}");
    for b in &d.bands {
        assert!(layers.contains(&b.name), "no layer {} in {layers:?}", b.name);
    }
    assert!(layers.contains(&MARK_LAYER.to_string()), "{layers:?}");
    let mut plate = Vec::new();
    let mut scratches = Vec::new();
    let mut marks = Vec::new();
    for e in back.entities() {
        match &e.specific {
            dxf::entities::EntityType::Line(ln) => {
                let seg = ([ln.p1.x, ln.p1.y], [ln.p2.x, ln.p2.y]);
                if e.common.layer == "plate" {
                    plate.push(seg);
                } else if e.common.layer == MARK_LAYER {
                    marks.push(seg);
                } else {
                    scratches.push((e.common.layer.clone(), seg));
                }
            }
            other => panic!("only LINE entities are written, found {other:?}"),
        }
    }
    let h = 0.5 * scene.plate.size_mm;
    assert_eq!(plate.len(), 4);
    for (a, _) in &plate {
        assert!(
            (a[0].abs() - h).abs() <= TOL && (a[1].abs() - h).abs() <= TOL,
            "plate corner {a:?}"
        );
    }
    let mk = d.mark.unwrap();
    assert!(
        marks.len() == 1 && close(marks[0].0, mk.a) && close(marks[0].1, mk.b),
        "{marks:?}"
    );
    assert_eq!(scratches.len(), scene.scratches.len());
    for (k, ((layer, (a, b)), s)) in scratches.iter().zip(&scene.scratches).enumerate() {
        assert!(
            close(*a, s.p0) && close(*b, s.p1),
            "scratch {}: {a:?} {b:?} vs {s:?}",
            k + 1
        );
        assert_eq!(layer, &d.bands[d.lines[k].band].name);
    }
}

#[test]
fn svg_and_dxf_read_back_banded_by_width() {
    let scene = design(300, 100.0);
    let d = drawing(&scene, None).unwrap();
    assert_eq!(d.by, BandBy::Width);
    let widths: Vec<f64> = scene.scratches.iter().map(|s| visible_width(s.w, s.d)).collect();
    bands_hold(&d, &widths);
    assert_eq!(d.bands.len(), MAX_BANDS, "300 random widths fill every band");
    check_svg(&scene, &d);
    check_dxf(&scene, &d, "width");
}

#[test]
fn svg_and_dxf_read_back_banded_by_depth() {
    let scene = design(120, 70.0);
    // Three commanded depths only: three bands, named by depth.
    let z: Vec<f64> = (0..120).map(|k| [0.02, 0.03, 0.05][k % 3]).collect();
    let d = drawing(&scene, Some(&z)).unwrap();
    assert_eq!(d.by, BandBy::Depth);
    assert_eq!(d.bands.len(), 3, "{:?}", d.bands);
    assert_eq!(d.bands[0].name, "band1_depth_20um");
    assert_eq!(d.bands[2].name, "band3_depth_50um");
    bands_hold(&d, &z);
    check_svg(&scene, &d);
    check_dxf(&scene, &d, "depth");
    // One depth for all: one band.
    let one = drawing(&scene, Some(&vec![0.04; 120])).unwrap();
    assert_eq!(one.bands.len(), 1);
    check_dxf(&scene, &one, "one");
    // A depth list of the wrong length is refused.
    assert!(drawing(&scene, Some(&z[..10]))
        .unwrap_err()
        .contains("10 depths for 120 scratches"));
}

/// Arc scratches read back at true size: each SVG `<path>`'s one `A` command, converted to its
/// centre by the SVG specification's rule (F.6.5), and each DXF `ARC` pass through the scratch's
/// ends and its arc's midpoint (so the sense is right, not only the circle).
#[test]
fn arcs_read_back_at_true_size() {
    let mut scene = design(60, 60.0);
    let h = 0.5 * scene.plate.size_mm;
    for (k, s) in scene.scratches.iter_mut().enumerate() {
        let b = [0.2, -0.6, 1.0, -1.5, 2.2, 0.0][k % 6];
        let mut t = *s;
        t.bulge = b;
        let bb = t.carved_bbox();
        if bb[0] >= -h && bb[1] >= -h && bb[2] <= h && bb[3] <= h {
            *s = t;
        }
    }
    let arcs = scene.scratches.iter().filter(|s| s.is_arc()).count();
    assert!(arcs >= 40, "{arcs} arcs");
    let d = drawing(&scene, None).unwrap();
    let mid = |s: &Scratch| {
        s.arc()
            .map_or([0.5 * (s.p0[0] + s.p1[0]), 0.5 * (s.p0[1] + s.p1[1])], |a| a.point(0.5))
    };
    // SVG.
    let text = svg(&d);
    let doc = roxmltree::Document::parse(&text).expect("the SVG parses");
    let l = scene.plate.size_mm;
    let back = |x: f64, y: f64| [x - 0.5 * l, 0.5 * l - y];
    let mut paths = 0;
    for p in doc.descendants().filter(|n| n.has_tag_name("path")) {
        let k: usize = p.attribute("id").unwrap()[1..].parse::<usize>().unwrap() - 1;
        let s = &scene.scratches[k];
        let w: Vec<&str> = p.attribute("d").unwrap().split_whitespace().collect();
        assert_eq!((w[0], w[3]), ("M", "A"), "{w:?}");
        let f = |i: usize| -> f64 { w[i].parse().unwrap() };
        let (x1, y1, r, large, sweep, x2, y2) = (f(1), f(2), f(4), f(7), f(8), f(9), f(10));
        assert!(
            close(back(x1, y1), s.p0) && close(back(x2, y2), s.p1),
            "scratch {}",
            k + 1
        );
        assert!((r - s.arc().unwrap().radius).abs() <= TOL);
        // Centre (F.6.5, rx = ry = r, no rotation), then the drawn arc's midpoint.
        let (xp, yp) = (0.5 * (x1 - x2), 0.5 * (y1 - y2));
        let sq = ((r * r - xp * xp - yp * yp) / (xp * xp + yp * yp)).max(0.0).sqrt();
        let sg = if large != sweep { 1.0 } else { -1.0 };
        let (cx, cy) = (sg * sq * yp + 0.5 * (x1 + x2), -sg * sq * xp + 0.5 * (y1 + y2));
        let t1 = (y1 - cy).atan2(x1 - cx);
        let mut dt = (y2 - cy).atan2(x2 - cx) - t1;
        if sweep == 1.0 && dt < 0.0 {
            dt += std::f64::consts::TAU;
        }
        if sweep == 0.0 && dt > 0.0 {
            dt -= std::f64::consts::TAU;
        }
        let m = back(cx + r * (t1 + 0.5 * dt).cos(), cy + r * (t1 + 0.5 * dt).sin());
        assert!(
            close2(m, mid(s)),
            "scratch {}: SVG midpoint {m:?} vs {:?}",
            k + 1,
            mid(s)
        );
        paths += 1;
    }
    assert_eq!(paths, arcs);
    // DXF.
    let path = std::env::temp_dir().join(format!("scratchart_export_{}_arcs.dxf", std::process::id()));
    std::fs::write(&path, dxf(&d)).unwrap();
    let back_dxf = dxf::Drawing::load_file(&path).expect("the DXF parses");
    let _ = std::fs::remove_file(&path);
    let mut read = 0;
    let on_layers: Vec<&Scratch> = scene.scratches.iter().filter(|s| s.is_arc()).collect();
    for e in back_dxf.entities() {
        if let dxf::entities::EntityType::Arc(a) = &e.specific {
            let s = on_layers[read];
            let at = |deg: f64| {
                [
                    a.center.x + a.radius * deg.to_radians().cos(),
                    a.center.y + a.radius * deg.to_radians().sin(),
                ]
            };
            let mut span = a.end_angle - a.start_angle;
            if span <= 0.0 {
                span += 360.0;
            }
            let (from, to) = if s.bulge > 0.0 { (s.p0, s.p1) } else { (s.p1, s.p0) };
            assert!(
                close2(at(a.start_angle), from) && close2(at(a.end_angle), to),
                "arc {read}"
            );
            assert!(close2(at(a.start_angle + 0.5 * span), mid(s)), "arc {read}: midpoint");
            read += 1;
        }
    }
    assert_eq!(read, arcs);
}

/// Within 0.1 um: the drawings' numbers have 9 decimals, and a half circle's centre found from
/// its ends and radius (the SVG rule) takes the square root of a difference near 0, which turns
/// 1e-9 mm of rounding into 3e-5 mm.
fn close2(a: [f64; 2], b: [f64; 2]) -> bool {
    (a[0] - b[0]).abs() <= 1e-4 && (a[1] - b[1]).abs() <= 1e-4
}
