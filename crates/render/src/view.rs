//! The camera view shared by the rasterizer and primary rays, so both agree on where every
//! pixel centre looks.

use geom::{Ray, Vec3};
use scene::Camera;
use trace::batch::{RayBatch, RayKind};

/// A pinhole view of `width × height` pixels. Pixel (x, y) has its centre at
/// (x + 0.5, y + 0.5); y grows downwards.
#[derive(Clone, Copy, Debug)]
pub struct View {
    /// Camera position.
    pub eye: Vec3,
    /// Unit right vector.
    pub right: Vec3,
    /// Unit up vector.
    pub up: Vec3,
    /// Unit forward vector (towards the target).
    pub fwd: Vec3,
    /// tan(vfov / 2).
    pub tan_y: f32,
    /// tan(vfov / 2) · width / height.
    pub tan_x: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Where in its pixel this view samples, in pixels from the centre (each in
    /// −0.5..0.5; zero for the centre). Antialiasing renders one view per sample
    /// ([`View::jittered`], [`sample_offset`]); the rasterizer samples pixel (x, y) at
    /// (x + 0.5 + `jitter[0]`, y + 0.5 + `jitter[1]`).
    pub jitter: [f32; 2],
}

/// The offset of sample `i` of `n` in its pixel (−0.5..0.5 each way): the Hammersley
/// points ((i + ½)/n, radical inverse of i in base 2), stratified along both axes. One
/// sample is the pixel's centre.
pub fn sample_offset(i: u32, n: u32) -> [f32; 2] {
    if n <= 1 {
        return [0.0, 0.0];
    }
    let x = (i as f32 + 0.5) / n as f32;
    let y = (i.reverse_bits() as f64 / 4_294_967_296.0) as f32;
    // The radical inverse starts at 0: shift it by half a stratum so both axes are centred.
    let y = y + 0.5 / n.next_power_of_two() as f32;
    [x - 0.5, y - 0.5]
}

impl View {
    /// The view of `cam` at `width × height` pixels.
    pub fn new(cam: &Camera, width: u32, height: u32) -> View {
        let (right, up, fwd) = cam.basis();
        let tan_y = (cam.vfov.to_radians() * 0.5).tan();
        View {
            eye: cam.eye,
            right,
            up,
            fwd,
            tan_y,
            tan_x: tan_y * width as f32 / height as f32,
            width,
            height,
            jitter: [0.0, 0.0],
        }
    }

    /// The same view sampling each pixel at `offset` from its centre (see [`View::jitter`]).
    pub fn jittered(self, offset: [f32; 2]) -> View {
        View {
            jitter: offset,
            ..self
        }
    }

    /// Camera-space coordinates (right, up, forward distance) of a world point.
    #[inline]
    pub fn to_camera(&self, p: Vec3) -> Vec3 {
        let d = p - self.eye;
        Vec3::new(d.dot(self.right), d.dot(self.up), d.dot(self.fwd))
    }

    /// Screen position (pixels, continuous) of a camera-space point in front of the eye.
    #[inline]
    pub fn to_screen(&self, c: Vec3) -> (f32, f32) {
        let sx = (c.x / c.z / self.tan_x + 1.0) * 0.5 * self.width as f32;
        let sy = (1.0 - c.y / c.z / self.tan_y) * 0.5 * self.height as f32;
        (sx, sy)
    }

    /// Unit direction through the continuous screen position (sx, sy).
    #[inline]
    pub fn dir_through(&self, sx: f32, sy: f32) -> Vec3 {
        let x = (2.0 * sx / self.width as f32 - 1.0) * self.tan_x;
        let y = (1.0 - 2.0 * sy / self.height as f32) * self.tan_y;
        (self.fwd + self.right * x + self.up * y).normalize()
    }

    /// The primary ray through the centre of pixel (x, y).
    #[inline]
    pub fn primary_ray(&self, x: u32, y: u32) -> Ray {
        Ray::new(
            self.eye,
            self.dir_through(x as f32 + 0.5, y as f32 + 0.5),
            0.0,
            f32::INFINITY,
        )
    }

    /// Primary rays for every pixel, row-major.
    pub fn primary_rays(&self) -> RayBatch {
        let n = (self.width * self.height) as usize;
        let mut b = RayBatch::with_capacity(n);
        for y in 0..self.height {
            for x in 0..self.width {
                b.push(
                    self.primary_ray(x, y),
                    RayKind::Primary,
                    y * self.width + x,
                    0,
                    Vec3::ONE,
                    0,
                );
            }
        }
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_and_rays_agree() {
        let cam = Camera {
            eye: Vec3::new(1.0, 2.0, 3.0),
            target: Vec3::new(0.0, 0.5, -1.0),
            up: Vec3::Y,
            vfov: 50.0,
        };
        let v = View::new(&cam, 320, 200);
        for (x, y) in [(0u32, 0u32), (319, 199), (160, 100), (17, 150)] {
            let r = v.primary_ray(x, y);
            let p = r.at(7.5);
            let (sx, sy) = v.to_screen(v.to_camera(p));
            assert!(
                (sx - (x as f32 + 0.5)).abs() < 1e-3 && (sy - (y as f32 + 0.5)).abs() < 1e-3,
                "{x},{y}: {sx},{sy}"
            );
        }
    }

    #[test]
    fn samples_are_stratified_inside_the_pixel() {
        assert_eq!(sample_offset(0, 1), [0.0, 0.0]);
        for n in [2u32, 4, 5, 8, 16] {
            let pts: Vec<[f32; 2]> = (0..n).map(|i| sample_offset(i, n)).collect();
            for p in &pts {
                assert!(p.iter().all(|c| (-0.5..0.5).contains(c)), "{n}: {p:?}");
            }
            // One sample per stratum of 1/n along x, and per stratum of 1/2^k along y.
            let k = n.next_power_of_two();
            for (axis, strata) in [(0, n), (1, k)] {
                let mut seen = vec![0; strata as usize];
                for p in &pts {
                    seen[((p[axis] + 0.5) * strata as f32) as usize] += 1;
                }
                assert!(seen.iter().all(|&c| c <= 1), "{n} axis {axis}: {seen:?}");
            }
        }
    }
}
