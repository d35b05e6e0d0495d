//! A perspective pinhole camera and the mapping from world space to pixel coordinates.
//!
//! Conventions: right-handed world; the camera looks from `eye` towards `target`; pixel
//! coordinates have their origin at the top-left corner of the image, x to the right, y down,
//! and the centre of pixel (i, j) at (i + 0.5, j + 0.5). There is no far plane: depth is
//! compared as 1/w (reciprocal view distance), which never saturates. The near plane sits at
//! [`Camera::near`].

use glam::{Mat4, Vec3, Vec4};

/// View space → homogeneous pixel coordinates of one camera (see
/// [`Camera::view_to_homogeneous_pixel`]).
#[derive(Clone, Copy, Debug)]
pub struct PixelProjection {
    half_width: f32,
    half_height: f32,
    focal: f32,
    /// The focal length over the aspect ratio.
    focal_x: f32,
}

impl PixelProjection {
    pub fn apply(&self, v: Vec3) -> Vec3 {
        let w = -v.z;
        let x = self.half_width * (self.focal_x * v.x + w);
        let y = self.half_height * (w - self.focal * v.y);
        Vec3::new(x, y, w)
    }
}

/// A perspective camera rendering a `width` × `height` image (square pixels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Full vertical field of view.
    pub fov_y_degrees: f32,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// World → view transform (right-handed, the camera looks down −z, +y up).
    pub fn view(&self) -> Mat4 {
        let forward = (self.target - self.eye).normalize();
        let right = forward.cross(self.up).normalize();
        let up = right.cross(forward);
        Mat4::from_cols(
            Vec4::new(right.x, up.x, -forward.x, 0.0),
            Vec4::new(right.y, up.y, -forward.y, 0.0),
            Vec4::new(right.z, up.z, -forward.z, 0.0),
            Vec4::new(-right.dot(self.eye), -up.dot(self.eye), forward.dot(self.eye), 1.0),
        )
    }

    /// Distance of the near clipping plane from the eye: 1/1000 of the eye–target distance.
    pub fn near(&self) -> f32 {
        (self.target - self.eye).length() * 1e-3
    }

    /// Width / height.
    pub fn aspect(&self) -> f32 {
        self.width as f32 / self.height as f32
    }

    /// `1 / tan(fov_y / 2)`.
    pub fn focal(&self) -> f32 {
        1.0 / (self.fov_y_degrees.to_radians() * 0.5).tan()
    }

    /// How wide a pixel is per unit of distance from the camera (across the line of sight).
    pub fn pixel_angle(&self) -> f32 {
        2.0 / (self.focal() * self.height as f32)
    }

    /// View space → homogeneous pixel coordinates `(X, Y, w)`: the pixel is `(X / w, Y / w)` and
    /// `w` is the distance in front of the camera along the view axis (`-z_view`).
    ///
    /// The map is linear, so clipping and interpolation can be done on `(X, Y, w)`.
    pub fn view_to_homogeneous_pixel(&self, v: Vec3) -> Vec3 {
        self.pixel_projection().apply(v)
    }

    /// [`Camera::view_to_homogeneous_pixel`] with its constants worked out once, for mapping
    /// many points (the same numbers, bit for bit).
    pub fn pixel_projection(&self) -> PixelProjection {
        let (w_px, h_px) = (self.width as f32, self.height as f32);
        let f = self.focal();
        PixelProjection { half_width: 0.5 * w_px, half_height: 0.5 * h_px, focal: f, focal_x: f / self.aspect() }
    }

    /// World point → (pixel x, pixel y, view distance along the axis), or `None` when the point
    /// is not in front of the near plane.
    pub fn project(&self, world: Vec3) -> Option<Vec3> {
        let h = self.view_to_homogeneous_pixel(self.view().transform_point3(world));
        (h.z >= self.near()).then(|| Vec3::new(h.x / h.z, h.y / h.z, h.z))
    }

    /// A camera looking at the centre of the box `[min, max]` from direction `direction`
    /// (pointing from the box towards the eye), placed just far enough that every corner of the
    /// box falls inside the image with `margin` (a fraction of the half-extent, e.g. 0.1 = 10 %)
    /// to spare on the tighter side.
    #[allow(clippy::too_many_arguments)]
    pub fn frame_box(
        min: Vec3,
        max: Vec3,
        direction: Vec3,
        up: Vec3,
        fov_y_degrees: f32,
        width: u32,
        height: u32,
        margin: f32,
    ) -> Camera {
        let target = (min + max) * 0.5;
        let dir = direction.normalize();
        let mut camera = Camera { eye: target + dir, target, up, fov_y_degrees, width, height };
        // Orientation only depends on `dir` and `up`; measure the corners in that frame.
        let view = camera.view();
        let tan_y = 1.0 / camera.focal() / (1.0 + margin);
        let tan_x = tan_y * camera.aspect();
        let mut distance = 0.0f32;
        for i in 0..8 {
            let corner = Vec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            );
            // Relative to the target in view axes: z is towards the eye.
            let v = view.transform_point3(corner) - view.transform_point3(target);
            distance = distance.max(v.z + v.x.abs() / tan_x).max(v.z + v.y.abs() / tan_y);
        }
        let extent = (max - min).length().max(f32::MIN_POSITIVE);
        camera.eye = target + dir * distance.max(extent * 1e-3);
        camera
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera {
            eye: Vec3::new(0.0, 0.0, 5.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y_degrees: 60.0,
            width: 200,
            height: 100,
        }
    }

    #[test]
    fn target_projects_to_the_image_centre_and_up_is_up() {
        let c = camera();
        let p = c.project(Vec3::ZERO).unwrap();
        assert!((p.x - 100.0).abs() < 1e-4 && (p.y - 50.0).abs() < 1e-4 && (p.z - 5.0).abs() < 1e-5);
        let up = c.project(Vec3::new(0.0, 1.0, 0.0)).unwrap();
        assert!(up.y < 50.0);
        let right = c.project(Vec3::new(1.0, 0.0, 0.0)).unwrap();
        assert!(right.x > 100.0);
        // The top edge of the view frustum maps to y = 0.
        let top = c.project(Vec3::new(0.0, 5.0 * (30f32).to_radians().tan(), 0.0)).unwrap();
        assert!(top.y.abs() < 1e-3, "{top}");
        assert!(c.project(Vec3::new(0.0, 0.0, 6.0)).is_none());
    }

    #[test]
    fn frame_box_fits_every_corner_with_margin() {
        let (min, max) = (Vec3::new(-1.0, -2.0, -0.5), Vec3::new(1.5, 2.0, 0.5));
        let c = Camera::frame_box(min, max, Vec3::new(0.3, 0.2, 1.0), Vec3::Y, 30.0, 485, 480, 0.1);
        let mut touches = false;
        for i in 0..8 {
            let corner = Vec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            );
            let p = c.project(corner).unwrap();
            let (dx, dy) = ((p.x - 242.5).abs() / 242.5, (p.y - 240.0).abs() / 240.0);
            assert!(dx <= 1.0 / 1.1 + 1e-3 && dy <= 1.0 / 1.1 + 1e-3, "{p}");
            touches |= (dx - 1.0 / 1.1).abs() < 1e-3 || (dy - 1.0 / 1.1).abs() < 1e-3;
        }
        assert!(touches, "the fit should be tight on one side");
    }
}
