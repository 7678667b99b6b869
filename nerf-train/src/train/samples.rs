//! Where a chunk's rays are sampled: stratified along each ray, kept where
//! the occupancy grid is occupied, or placed by the proposal grid.

use super::*;

impl Trainer {
    /// Stratified samples of every ray of a chunk (jitter key per ray from
    /// `key`), kept where the grid is occupied: fills `t_c` (all `sampling.n_coarse`
    /// per ray) and `pos`, `delta`, `offs`, `dirs` (per kept sample with a
    /// grid, per ray without).
    pub(super) fn coarse_samples(&self, rays: &[Sample], key: impl Fn(usize) -> u32, ws: &mut Workspace) {
        let nc = self.main_samples();
        let intervals = self.cfg.loss.distortion > 0.0;
        let grid = self.grid.as_ref().map(|g| g.view());
        ws.t_c.resize(rays.len() * nc, 0.0);
        ws.start_samples();
        ws.foot.clear();
        ws.dirs.clear();
        ws.kept.clear();
        if self.proposal.is_some() {
            ws.props.resize_with(rays.len(), Default::default);
        }
        // with footprints, every sample has its K points (a ray without one: its sample K times)
        const K: usize = nerf_infer::camera::FOOTPRINT_POINTS;
        let any_foot = rays.iter().any(|s| s.ray.foot.is_some());
        for (i, Sample { ray, .. }) in rays.iter().enumerate() {
            let t = &mut ws.t_c[i * nc..(i + 1) * nc];
            match &self.proposal {
                Some(pg) => pg.place(ray, key(i), self.cfg.sampling.n_coarse as usize, t, &mut ws.props[i]),
                None => ray.stratified(Some(key(i)), t),
            }
            match grid {
                None => {
                    ws.kept.extend(0..nc as u32);
                    for &ti in t.iter() {
                        let p = ray.at(ti).to_array();
                        ws.pos.push(p);
                        if any_foot {
                            ws.foot.extend(ray.foot_at(ti).unwrap_or([p; K]));
                        }
                    }
                    push_deltas(t, ray.dir_len, &mut ws.delta);
                    if intervals {
                        (0..nc).for_each(|j| push_interval(ray, t, j, &mut ws.s_mid, &mut ws.s_width));
                    }
                    ws.dirs.push(ray.viewdir.to_array());
                }
                Some(g) => {
                    for j in 0..nc {
                        let p = ray.at(t[j]).to_array();
                        if g.at_f32(p) {
                            ws.kept.push(j as u32);
                            ws.pos.push(p);
                            if any_foot {
                                ws.foot.extend(ray.foot_at(t[j]).unwrap_or([p; K]));
                            }
                            ws.delta.push(if j + 1 < nc { (t[j + 1] - t[j]) * ray.dir_len } else { LAST_DELTA });
                            if intervals {
                                push_interval(ray, t, j, &mut ws.s_mid, &mut ws.s_width);
                            }
                            ws.dirs.push(ray.viewdir.to_array());
                        }
                    }
                }
            }
            ws.offs.push(ws.pos.len());
        }
    }
}
