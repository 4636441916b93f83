//! The domain sampled on a grid over the box, for the messages of a failed run.

use super::mesh::Job;

/// The domain sampled on a grid over the box: where it is inside, and the size there.
pub struct DomainSample {
    pub inside: usize,
    pub lo: [f64; 3],
    pub hi: [f64; 3],
    pub step: [f64; 3],
    pub h_min: f64,
    pub h_max: f64,
    pub h_max_at: [f64; 3],
}

impl DomainSample {
    pub fn new(job: &Job) -> DomainSample {
        let dim = job.dim;
        let n = if dim == 3 { 64 } else { 400 };
        let b = &job.bbox;
        let mut step = [0.0; 3];
        for k in 0..dim {
            step[k] = (b[k + dim] - b[k]) / n as f64;
        }
        let mut s = DomainSample {
            inside: 0,
            lo: [f64::INFINITY; 3],
            hi: [f64::NEG_INFINITY; 3],
            step,
            h_min: f64::INFINITY,
            h_max: 0.0,
            h_max_at: [0.0; 3],
        };
        let nz = if dim == 3 { n } else { 0 };
        for kz in 0..=nz {
            for j in 0..=n {
                for i in 0..=n {
                    let mut p = [b[0] + step[0] * i as f64, b[1] + step[1] * j as f64, 0.0];
                    if dim == 3 {
                        p[2] = b[2] + step[2] * kz as f64;
                    }
                    let d = job.domain.eval(p[0], p[1], p[2]);
                    if d.is_nan() || d >= 0.0 {
                        continue;
                    }
                    s.inside += 1;
                    for (k, &x) in p.iter().enumerate().take(dim) {
                        s.lo[k] = s.lo[k].min(x);
                        s.hi[k] = s.hi[k].max(x);
                    }
                    if let Some(h) = &job.size {
                        let v = h.eval(p[0], p[1], p[2]);
                        if v.is_finite() && v > 0.0 {
                            s.h_min = s.h_min.min(v);
                            if v > s.h_max {
                                s.h_max = v;
                                s.h_max_at = p;
                            }
                        }
                    }
                }
            }
        }
        s
    }
}
