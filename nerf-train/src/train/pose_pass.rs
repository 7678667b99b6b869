//! The pose corrections' part of a step ([`crate::per_photo::pose`]): rays drawn
//! through the corrected cameras, and the corrections' gradient from the
//! gradient of the sample positions.

use super::*;
use crate::per_photo::pose::{self, Poses};
use glam::Vec3;
use nerf_infer::camera::FOOTPRINT_POINTS;

impl Trainer {
    /// Whether this run fits pose corrections: [`PerPhotoConfig::pose_refine`](crate::config::PerPhotoConfig::pose_refine)
    /// in a scene that is not forward-facing (NDC rays keep their poses).
    pub fn refines_poses(&self) -> bool {
        self.cfg.per_photo.pose_refine && self.scene.ndc.is_none()
    }

    /// [`Trainer::draw_batch`] through the cameras as `poses` corrects them
    /// (`None`: as loaded).
    pub fn draw_batch_posed(data: &Dataset, n: usize, how: Draw, rng: &mut Rng, poses: Option<&Poses>) -> Vec<Sample> {
        Self::draw_with(data, n, how, rng, |vi, o, d| match poses {
            Some(p) if vi < p.photos() => p.apply(vi, o, d),
            _ => (o, d),
        })
    }

    /// The photos' corrections' gradients of the mean squared colour
    /// error over `batch` (the pass of [`Trainer::gradients`] under
    /// `step_key`): the pose's where the run [`Trainer::refines_poses`] and
    /// holds [`Trainer::poses`], the colour's with [`Trainer::appearance`].
    pub fn photo_gradients(&self, batch: &[Sample], step_key: u32) -> PerPhoto {
        self.gradients_timed(batch, step_key, &mut StepTimes::default()).4
    }

    /// One Adam step of the pose corrections on the step's gradient `grad`
    /// (as [`Poses::params`]) at [`PerPhotoConfig::pose_lr`](crate::config::PerPhotoConfig::pose_lr),
    /// decayed as the network's `lr` (this step's rate) is.
    pub(super) fn step_poses(&mut self, grad: &mut [f32], lr: f32) {
        let c = &self.cfg;
        let Some(p) = self.poses.as_mut().filter(|p| grad.len() == p.params.len()) else { return };
        if grad.iter().all(|g| g.is_finite()) {
            let lr = c.per_photo.pose_lr * lr / c.optimiser.lr;
            p.update(grad, lr, c.optimiser.beta1, c.optimiser.beta2, c.optimiser.eps);
        }
    }

    /// After the backward pass of a chunk's only network (parameters `p`,
    /// activations `ws.acts_c` kept with their input gradient): adds each
    /// ray's share of its photo's correction gradient to `ws.dpose`.
    pub(super) fn pose_backward(&self, net: &Mlp, p: &[f32], rays: &[Sample], ws: &mut Workspace) {
        let Some(poses) = &self.poses else { return };
        let (mut gamma, mut grid) = (std::mem::take(&mut ws.dpos), std::mem::take(&mut ws.dgrid));
        net.position_gradient(p, &ws.acts_c, &ws.samples.pos, &ws.samples.foot, &mut gamma, &mut grid);
        let mut views = std::mem::take(&mut ws.ddir);
        net.direction_gradient(&ws.acts_c, &ws.samples.dirs, &mut views);
        // the pass's directions: one per kept sample with an occupancy grid, one per ray without
        let per_sample = self.sampler.occupancy.is_some();
        ws.dpose.resize(poses.params.len(), 0.0);
        let k = if grid.len() > ws.samples.pos.len() { FOOTPRINT_POINTS } else { 1 };
        let nc = self.main_samples();
        let s = &self.scene;
        let inv_half = 2.0 / (Vec3::from(s.bounds_max) - Vec3::from(s.bounds_min));
        for (i, sample) in rays.iter().enumerate() {
            let ray = &sample.ray;
            let contract = ray.linear_until.is_some();
            // gradients with respect to the normalised origin and direction
            let (mut go, mut gd) = (Vec3::ZERO, Vec3::ZERO);
            for si in ws.samples.offs[i]..ws.samples.offs[i + 1] {
                let t = ws.samples.t[i * nc + ws.samples.kept[si] as usize];
                let q = ray.norm_origin + t * ray.norm_dir;
                let mut add = |q: Vec3, g: [f32; 3]| {
                    let g = if contract { contract_back(q, Vec3::from(g)) } else { Vec3::from(g) };
                    go += g;
                    gd += t * g;
                };
                add(q, gamma[si]);
                if grid.is_empty() {
                    continue;
                }
                match (k, ray.foot) {
                    (1, _) => add(q, grid[si]),
                    (_, Some(foot)) => (0..k).for_each(|m| add(q + t * foot[m], grid[si * k + m])),
                    (_, None) => (0..k).for_each(|m| add(q, grid[si * k + m])),
                }
            }
            // the view direction d/|d| (world space): its gradient projected off d, over |d|
            let rows = if per_sample { ws.samples.offs[i]..ws.samples.offs[i + 1] } else { i..i + 1 };
            let gv: Vec3 = views.get(rows).map_or(Vec3::ZERO, |r| r.iter().map(|g| Vec3::from(*g)).sum());
            let u = ray.viewdir;
            let g_dir = inv_half * gd + (gv - u * u.dot(gv)) / ray.dir_len;
            let v = sample.view as usize;
            if v < poses.photos() {
                let dp = &mut ws.dpose[v * pose::PER_PHOTO..(v + 1) * pose::PER_PHOTO];
                pose::ray_back(u * ray.dir_len, inv_half * go, g_dir, dp);
            }
        }
        (ws.dpos, ws.dgrid, ws.ddir) = (gamma, grid, views);
    }
}

/// `Jᵀ·g` for the contraction ([`nerf_infer::unbounded::contract_f32`]) at
/// the normalised position `q`: the gradient with respect to `q` from `g`,
/// the gradient with respect to the contracted position.
pub fn contract_back(q: Vec3, g: Vec3) -> Vec3 {
    let a = q.abs();
    let m = a.max_element();
    if m <= 1.0 {
        return 0.5 * g;
    }
    // x = q·s(m), s = 1/m − 1/(2m²); m = |q_k| for the largest axis k
    let s = (1.0 - 0.5 / m) / m;
    let ds = -1.0 / (m * m) + 1.0 / (m * m * m);
    let k = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let mut out = s * g;
    out[k] += q[k].signum() * ds * q.dot(g);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use nerf_infer::unbounded::contract_f32;

    #[test]
    fn contract_back_matches_finite_differences() {
        let g = Vec3::new(0.3, -0.7, 0.5);
        for q in
            [Vec3::new(0.2, -0.5, 0.7), Vec3::new(1.7, -0.4, 0.9), Vec3::new(0.3, -3.0, 2.1), Vec3::new(-0.2, 1.0, 6.0)]
        {
            let back = contract_back(q, g);
            let h = 1e-3;
            for a in 0..3 {
                let (mut p, mut m) = (q, q);
                p[a] += h;
                m[a] -= h;
                let fd = (g.dot(contract_f32(p)) - g.dot(contract_f32(m))) / (2.0 * h);
                assert!((fd - back[a]).abs() < 2e-3, "{q} axis {a}: {fd} against {}", back[a]);
            }
        }
    }
}
