//! A render of part of each image (`Renderer::upload_windowed`, the set-up sheet's searches):
//! inside each view's window the pixels are bit for bit those of the whole image's render, and
//! outside it they are 0; a window names whole 16-pixel tiles, clipped to the image.
use scratchart_render::layout::TileWindow;
use scratchart_render::Renderer;
use scratchart_tests::*;

#[test]
fn a_window_renders_its_tiles_as_the_whole_image_does() {
    // Three views of 72, 100 and 40 pixels (not multiples of a tile), 3000 scratches.
    let mut scene = two_view_scene(7, 3000, 72, 100);
    scene.views.push(orbit_view("c", 40, 35.0, 240.0, 45.0, 180.0, 20.0));
    let ctx = gpu();
    let r = Renderer::new(&ctx).expect("pipelines");
    let whole = {
        let mut gs = r.upload(&scene).expect("upload");
        r.render(&mut gs).expect("render").images
    };
    let lit = |img: &[f32]| img.iter().filter(|&&v| v > 0.0).count();
    assert!(whole.iter().all(|img| lit(img) > 100), "every view shows scratches");
    let windows = [
        // The middle of view a, the bottom-right corner of view b (its partial tiles), all of c.
        [
            Some(TileWindow::covering(72, 72, 20, 17, 50, 40)),
            Some(TileWindow::covering(100, 100, 70, 81, 100, 100)),
            None,
        ],
        // One tile of a, none given for b (the whole image), a window past c's edge (clipped).
        [
            Some(TileWindow {
                x0: 2,
                y0: 1,
                nx: 1,
                ny: 1,
            }),
            None,
            Some(TileWindow {
                x0: 1,
                y0: 0,
                nx: 9,
                ny: 9,
            }),
        ],
    ];
    for set in windows {
        let mut gs = r.upload_windowed(&scene, &set).expect("upload");
        let images = r.render(&mut gs).expect("render").images;
        for (v, (img, full)) in images.iter().zip(&whole).enumerate() {
            let (w, h) = (scene.views[v].camera.width, scene.views[v].camera.height);
            let win = set[v].map_or_else(|| TileWindow::whole(w, h), |t| t.clipped(w, h));
            let (mut inside, mut lit_inside) = (0, 0);
            for (k, (&a, &b)) in img.iter().zip(full).enumerate() {
                let (x, y) = (k as u32 % w, k as u32 / w);
                if win.contains(x, y) {
                    assert_eq!(a.to_bits(), b.to_bits(), "view {v} pixel ({x}, {y}): {a} against {b}");
                    inside += 1;
                    lit_inside += (a > 0.0) as usize;
                } else {
                    assert_eq!(a, 0.0, "view {v} pixel ({x}, {y}) outside its window");
                }
            }
            assert!(inside > 0 && lit_inside > 0, "view {v}: its window shows scratches");
            if set[v].is_some() && win != TileWindow::whole(w, h) {
                assert!(inside < img.len(), "view {v}: a window smaller than the image");
            }
        }
    }
    assert_no_validation(&ctx);
}

#[test]
fn a_window_covers_the_pixels_it_is_asked_for() {
    // Pixels [20, 50) x [17, 40) of a 72-pixel image: tiles 1..4 across (16..64), 1..3 down.
    let t = TileWindow::covering(72, 72, 20, 17, 50, 40);
    assert_eq!((t.x0, t.y0, t.nx, t.ny), (1, 1, 3, 2));
    for (x, y) in [(20, 17), (49, 39), (16, 16), (63, 47)] {
        assert!(t.contains(x, y), "({x}, {y})");
    }
    for (x, y) in [(15, 20), (64, 20), (30, 48), (30, 15)] {
        assert!(!t.contains(x, y), "({x}, {y})");
    }
    // Past the edge: clipped, at least one tile.
    let c = TileWindow::covering(40, 40, 200, 300, 400, 500);
    assert_eq!((c.x0, c.y0, c.nx, c.ny), (2, 2, 1, 1));
    assert_eq!(
        TileWindow::whole(40, 33),
        TileWindow {
            x0: 0,
            y0: 0,
            nx: 3,
            ny: 3
        }
    );
}
