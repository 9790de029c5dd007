//! Where the panels go in the window: the refocus image (aspect kept, centred in its half), the
//! scene view (the other half), and a status strip along the bottom. Side by side when the
//! window is wider than tall, stacked otherwise. Pure arithmetic on window pixels.

use glam::DVec2;

use crate::passes::panel::Rect;

/// Height of the status strip: two lines of 2× scaled 8-pixel glyphs with spacing.
pub const STATUS_HEIGHT: u32 = 44;

/// The panels of one window size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layout {
    pub window: (u32, u32),
    /// The refocus image, with the view's aspect ratio.
    pub refocus: Rect,
    /// The half of the window the refocus image is centred in.
    pub refocus_area: Rect,
    pub scene: Rect,
    pub status: Rect,
}

impl Layout {
    /// The layout of a `width × height` window showing views of `view` = (width, height).
    pub fn new(width: u32, height: u32, view: (u32, u32)) -> Self {
        let (w, h) = (width as f32, height as f32);
        let status_h = (STATUS_HEIGHT as f32).min(h);
        let body_h = (h - status_h).max(0.0);
        let (area, scene) = if w >= body_h {
            let half = (w / 2.0).floor();
            (
                Rect::new(0.0, 0.0, half, body_h),
                Rect::new(half, 0.0, w - half, body_h),
            )
        } else {
            let half = (body_h / 2.0).floor();
            (
                Rect::new(0.0, 0.0, w, half),
                Rect::new(0.0, half, w, body_h - half),
            )
        };
        let aspect = view.0.max(1) as f32 / view.1.max(1) as f32;
        let (mut rw, mut rh) = (area.width, area.width / aspect);
        if rh > area.height {
            rh = area.height;
            rw = rh * aspect;
        }
        let refocus = Rect::new(
            area.x + ((area.width - rw) / 2.0).floor(),
            area.y + ((area.height - rh) / 2.0).floor(),
            rw,
            rh,
        );
        Layout {
            window: (width, height),
            refocus,
            refocus_area: area,
            scene,
            status: Rect::new(0.0, body_h, w, status_h),
        }
    }

    /// The refocus image position (pixel-index coordinates of an image of `size`) under window
    /// position `(x, y)`, or `None` outside the image.
    pub fn refocus_pixel(&self, x: f64, y: f64, size: (u32, u32)) -> Option<DVec2> {
        let r = self.refocus;
        if r.is_empty() || !r.contains(x, y) {
            return None;
        }
        let u = (x - r.x as f64) / r.width as f64 * size.0 as f64 - 0.5;
        let v = (y - r.y as f64) / r.height as f64 * size.1 as f64 - 0.5;
        Some(DVec2::new(u, v))
    }

    /// The window position of refocus image position `p` (inverse of [`Layout::refocus_pixel`]).
    pub fn refocus_to_window(&self, p: DVec2, size: (u32, u32)) -> DVec2 {
        let r = self.refocus;
        DVec2::new(
            r.x as f64 + (p.x + 0.5) / size.0 as f64 * r.width as f64,
            r.y as f64 + (p.y + 0.5) / size.1 as f64 * r.height as f64,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wide_windows_put_panels_side_by_side_and_keep_the_aspect() {
        let l = Layout::new(1200, 644, (512, 512));
        assert_eq!(l.status, Rect::new(0.0, 600.0, 1200.0, 44.0));
        assert_eq!(l.scene, Rect::new(600.0, 0.0, 600.0, 600.0));
        assert_eq!(l.refocus, Rect::new(0.0, 0.0, 600.0, 600.0));
        // A wide view is letterboxed in its half.
        let l = Layout::new(1200, 644, (600, 300));
        assert_eq!(l.refocus, Rect::new(0.0, 150.0, 600.0, 300.0));
        // Tall windows stack.
        let l = Layout::new(400, 844, (100, 100));
        assert_eq!(l.refocus_area, Rect::new(0.0, 0.0, 400.0, 400.0));
        assert_eq!(l.scene, Rect::new(0.0, 400.0, 400.0, 400.0));
    }

    #[test]
    fn window_and_refocus_pixels_round_trip() {
        let l = Layout::new(1000, 544, (64, 32));
        let size = (64, 32);
        for p in [
            DVec2::new(0.0, 0.0),
            DVec2::new(63.0, 31.0),
            DVec2::new(10.25, 7.5),
        ] {
            let w = l.refocus_to_window(p, size);
            let back = l.refocus_pixel(w.x, w.y, size).unwrap();
            assert!((back - p).length() < 1e-9, "{p} → {w} → {back}");
        }
        assert_eq!(l.refocus_pixel(999.0, 10.0, size), None);
        // Window pixel centres map to image pixel centres when the panel is an integer scale.
        let l = Layout::new(128, 108, (64, 32));
        let p = l
            .refocus_pixel(l.refocus.x as f64 + 0.5, l.refocus.y as f64 + 0.5, size)
            .unwrap();
        assert_eq!(p, DVec2::new(0.0, 0.0));
    }
}
