//! The orbit a video follows around the scene: fitted to the training
//! cameras when the model is trained ([`fit_orbit`], stored in the model
//! as a [`FittedOrbit`]); `nerf-infer`'s [`Orbit`] follows it, or for a
//! model without one, a circle chosen from its scene.

use crate::dataset::fit::{focus_point, Pose};
use glam::{DMat3, DVec3, Vec3};
use nerf_infer::format::{FittedOrbit, Scene};
use nerf_infer::orbit::azimuth_axes;
use nerf_infer::{Camera, Orbit};

/// Rays of `views` cameras on the scene's own orbit ([`Orbit::new`] without a
/// fitted one), `size`² pixels each, with zero ground truth (for
/// calibration); none at `size` 0.
pub fn orbit_rays(scene: &Scene, views: usize, size: u32) -> Vec<crate::train::Sample> {
    let o = Orbit::new(scene, None);
    let mut out = Vec::new();
    for k in 0..views {
        // a camera the orbit cannot make (of no pixels) has no rays
        let Ok(cam) = o.camera(k as f32 / views as f32, size, size) else { continue };
        for y in 0..size {
            for x in 0..size {
                let (o, d) = cam.ray(x, y);
                if let Some(r) = nerf_infer::Ray::new(scene, o, d) {
                    out.push(crate::train::Sample::on_scene(scene, r, [0.0; 3]));
                }
            }
        }
    }
    out
}

/// The median of `v` (sorted in place); `v` not empty.
fn median(v: &mut [f32]) -> f32 {
    v.sort_by(f32::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Eigenvalues of the symmetric matrix `a`, ascending, with their unit
/// eigenvectors (cyclic Jacobi rotations, to f64 round-off).
fn symmetric_eigen(a: DMat3) -> [(f64, DVec3); 3] {
    let mut m = [a.x_axis.to_array(), a.y_axis.to_array(), a.z_axis.to_array()];
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..32 {
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if m[p][q].abs() <= 1e-300 {
                continue;
            }
            // the rotation in the (p, q) plane that zeroes m[p][q]
            let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let (c, s) = (1.0 / (t * t + 1.0).sqrt(), t / (t * t + 1.0).sqrt());
            for row in m.iter_mut() {
                let (x, y) = (row[p], row[q]);
                (row[p], row[q]) = (c * x - s * y, s * x + c * y);
            }
            for k in 0..3 {
                let (x, y) = (m[p][k], m[q][k]);
                (m[p][k], m[q][k]) = (c * x - s * y, s * x + c * y);
            }
            for row in v.iter_mut() {
                let (x, y) = (row[p], row[q]);
                (row[p], row[q]) = (c * x - s * y, s * x + c * y);
            }
        }
    }
    // column k of v (rows hold the components) is the eigenvector of m[k][k]
    let mut out = [0, 1, 2].map(|k| (m[k][k], DVec3::new(v[0][k], v[1][k], v[2][k]).normalize()));
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

/// The unit vector least aligned with the cameras' right axes (the
/// eigenvector of the smallest eigenvalue `λ₁` of their mean outer
/// product, whose eigenvalues sum to 1), turned to the side of `mean_up`;
/// `mean_up` when the next eigenvalue `λ₂` is below 0.01 or 4·λ₁ (the
/// right axes do not spread enough to fix a plane) or `λ₁` is above 0.05
/// (they do not lie near one: the cameras roll).
fn level_up(cams: &[Camera], mean_up: Vec3) -> Vec3 {
    let n = cams.len() as f64;
    let s = cams.iter().fold(DMat3::ZERO, |m, c| {
        let r = c.rotation.x_axis.as_dvec3();
        m + DMat3::from_cols(r * r.x, r * r.y, r * r.z)
    }) * (1.0 / n);
    let [(l_min, v_min), (l_mid, _), _] = symmetric_eigen(s);
    let up = v_min.as_vec3();
    if !(l_mid >= 0.01 && l_mid >= 4.0 * l_min && l_min <= 0.05 && up.is_finite()) {
        return mean_up;
    }
    if up.dot(mean_up) < 0.0 {
        -up
    } else {
        up
    }
}

/// The orbit fitted to a capture's cameras `cams` (in the model's frame)
/// in a scene `scene`:
///
/// - up: perpendicular to every camera's right axis (the least-squares
///   direction: a camera held level has its right axis horizontal, however
///   it is tilted up or down), on the side of the mean of their up axes;
///   that mean itself when the right axes do not spread (under about 6°
///   RMS, as in a capture that walks straight ahead) or do not lie near
///   one plane (cameras that roll);
/// - centre: the point nearest (least squares) to every camera's optical
///   axis, where the capture looks, or the bounds' centre when the axes
///   are (nearly) parallel or meet outside the bounds;
/// - radius and height: the medians of the cameras' distances from the
///   axis through the centre along up and of their heights along it;
/// - field of view: the median of the cameras' horizontal ones;
/// - first azimuth: the direction of the mean of the cameras' unit
///   directions around the axis (the middle of a capture that covers an
///   arc; for one all around, wherever the sum points).
///
/// `None` (the model then orbits as [`Orbit::new`] chooses without one) for
/// forward-facing (NDC) scenes, whose spiral follows the capture already,
/// for no cameras, and when the cameras' ups cancel, they sit on the axis
/// (radius 0) or nearly so (|height| > 100·radius).
pub fn fit_orbit(scene: &Scene, cams: &[Camera]) -> Option<FittedOrbit> {
    if scene.ndc.is_some() || cams.is_empty() {
        return None;
    }
    let mean_up = cams.iter().map(|c| c.rotation.y_axis).sum::<Vec3>().try_normalize()?;
    let up = level_up(cams, mean_up);
    let poses: Vec<Pose> = cams.iter().map(|c| (c.rotation.as_dmat3(), c.position.as_dvec3())).collect();
    let (lo, hi) = (Vec3::from(scene.bounds_min), Vec3::from(scene.bounds_max));
    let centre = focus_point(&poses)
        .map(|p| p.as_vec3())
        .filter(|p| p.is_finite() && p.cmpge(lo).all() && p.cmple(hi).all())
        .unwrap_or(0.5 * (lo + hi));
    let height = |c: &Camera| (c.position - centre).dot(up);
    let radius = median(&mut cams.iter().map(|c| (c.position - centre - height(c) * up).length()).collect::<Vec<_>>());
    let height = median(&mut cams.iter().map(height).collect::<Vec<_>>());
    let fov_x = median(&mut cams.iter().map(|c| 2.0 * (0.5 * c.width as f32 / c.fx).atan()).collect::<Vec<_>>());
    let (u1, u2) = azimuth_axes(up);
    let around: glam::Vec2 = cams
        .iter()
        .map(|c| glam::Vec2::new((c.position - centre).dot(u1), (c.position - centre).dot(u2)).normalize_or_zero())
        .sum();
    let azimuth = around.y.atan2(around.x);
    let o = FittedOrbit { centre: centre.to_array(), up: up.to_array(), radius, height, fov_x, azimuth };
    o.is_valid().then_some(o)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nerf_infer::orbit::OrbitKind;

    fn scene(half: f32) -> Scene {
        Scene::blender(half, 0.1, 10.0)
    }

    #[test]
    fn an_orbit_of_images_of_no_pixels_has_no_rays() {
        assert!(orbit_rays(&scene(1.0), 4, 0).is_empty());
        assert!(!orbit_rays(&scene(1.0), 2, 3).is_empty());
    }

    /// A ring of `n` cameras around `centre`, `r` from the axis along `up`
    /// and `h` above it, looking at `centre`, 60° across.
    fn ring(n: usize, centre: Vec3, up: Vec3, r: f32, h: f32) -> Vec<Camera> {
        let o = Orbit {
            kind: OrbitKind::Circle,
            centre: centre.to_array(),
            up: up.to_array(),
            radius: r.hypot(h),
            elevation: h.atan2(r),
            azimuth: 0.0,
            fov_x: 60f32.to_radians(),
        };
        (0..n).map(|k| o.camera(k as f32 / n as f32, 40, 30).unwrap()).collect()
    }

    #[test]
    fn a_fitted_orbit_follows_the_captures_circle_up_and_field_of_view() {
        // cameras on a tilted ring around an off-centre point, with some shake
        let (centre, up) = (Vec3::new(0.3, -0.2, 0.1), Vec3::new(0.0, 0.6, 0.8));
        let mut cams = ring(24, centre, up, 2.0, 0.7);
        for (i, c) in cams.iter_mut().enumerate() {
            c.position += 0.02 * Vec3::new((i % 3) as f32 - 1.0, (i % 2) as f32 - 0.5, 0.0);
        }
        let f = fit_orbit(&scene(3.0), &cams).unwrap();
        assert!((Vec3::from(f.centre) - centre).length() < 0.05, "{:?}", f.centre);
        assert!(Vec3::from(f.up).dot(up) > 0.999, "{:?}", f.up);
        assert!((f.radius - 2.0).abs() < 0.05 && (f.height - 0.7).abs() < 0.05, "{f:?}");
        assert!((f.fov_x - 60f32.to_radians()).abs() < 1e-4);
        // its cameras look at the centre from the ring, upright
        let o = Orbit::new(&scene(3.0), Some(&f));
        for t in [0.0, 0.3, 0.7] {
            let c = o.camera(t, 16, 16).unwrap();
            let rel = c.position - Vec3::from(f.centre);
            assert!((rel.dot(Vec3::from(f.up)) - f.height).abs() < 1e-4, "height at {t}");
            assert!((-c.rotation.z_axis).dot(-rel.normalize()) > 0.9999, "looks at the centre");
            assert!(c.rotation.y_axis.dot(Vec3::from(f.up)) > 0.0, "upright");
        }
    }

    /// A circle around the origin, radius 2, up +z, 0.3 rad above the
    /// plane (its cameras look down 0.3 rad), from `azimuth`.
    fn looking_down(azimuth: f32) -> Orbit {
        let (centre, up) = ([0.0; 3], [0.0, 0.0, 1.0]);
        Orbit { kind: OrbitKind::Circle, centre, up, radius: 2.0, elevation: 0.3, azimuth, fov_x: 0.8 }
    }

    #[test]
    fn a_capture_over_an_arc_starts_the_orbit_in_its_middle() {
        // 9 cameras over a quarter turn centred at azimuth 1 rad, up +z
        let o = looking_down(1.0 - std::f32::consts::FRAC_PI_4);
        let cams: Vec<Camera> = (0..9).map(|k| o.camera(k as f32 / 32.0, 20, 20).unwrap()).collect();
        let f = fit_orbit(&scene(3.0), &cams).unwrap();
        // level cameras looking down: up from their right axes is +z, where their mean up leans
        // towards the arc's middle by about the 0.3 rad they look down
        assert!(Vec3::from(f.up).dot(Vec3::Z) > 0.9999, "{:?}", f.up);
        let mean_up = cams.iter().map(|c| c.rotation.y_axis).sum::<Vec3>().normalize();
        assert!(mean_up.dot(Vec3::Z) < 0.99, "{mean_up}");
        assert!((f.azimuth - 1.0).abs() < 1e-3, "{}", f.azimuth);
        // the first frame of the fitted orbit is the middle camera's view
        let first = Orbit::new(&scene(3.0), Some(&f)).camera(0.0, 20, 20).unwrap();
        assert!((first.position - cams[4].position).length() < 1e-3, "{} against {}", first.position, cams[4].position);
    }

    #[test]
    fn the_eigen_solver_recovers_a_rotated_diagonal_matrix() {
        let r = DMat3::from_quat(glam::DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 0.7));
        let a = r * DMat3::from_diagonal(DVec3::new(0.5, 0.01, 0.2)) * r.transpose();
        let e = symmetric_eigen(a);
        for ((l, v), (want_l, col)) in e.iter().zip([(0.01, 1), (0.2, 2), (0.5, 0)]) {
            assert!((l - want_l).abs() < 1e-12, "{l} against {want_l}");
            assert!(v.dot(r.col(col)).abs() > 1.0 - 1e-12);
            assert!((a * *v - *l * *v).length() < 1e-12);
        }
    }

    #[test]
    fn a_narrow_arc_of_level_cameras_stands_the_orbit_up() {
        // 40° of arc looking down 0.3 rad: the right axes spread little, their mean up leans 17°
        let o = looking_down(-0.35);
        let cams: Vec<Camera> =
            (0..8).map(|k| o.camera(k as f32 * 0.7 / 7.0 / std::f32::consts::TAU, 20, 20).unwrap()).collect();
        let f = fit_orbit(&scene(3.0), &cams).unwrap();
        assert!(Vec3::from(f.up).dot(Vec3::Z) > 1.0 - 1e-7, "{:?}", f.up);
        assert!(f.azimuth.abs() < 1e-3, "{}", f.azimuth);
    }

    #[test]
    fn a_capture_looking_outside_the_bounds_orbits_the_bounds_centre() {
        // cameras looking at a point outside the bounds
        let cams = ring(12, Vec3::new(5.0, 0.0, 0.0), Vec3::Z, 1.0, 0.0);
        let f = fit_orbit(&scene(1.0), &cams).unwrap();
        assert_eq!(f.centre, [0.0; 3]);
        // no cameras, or a forward-facing scene: no fitted orbit
        assert!(fit_orbit(&scene(1.0), &[]).is_none());
        let mut ndc = scene(1.0);
        ndc.ndc = Some(nerf_infer::format::Ndc { focal: 30.0, width: 40.0, height: 30.0 });
        assert!(fit_orbit(&ndc, &cams).is_none());
    }
}
