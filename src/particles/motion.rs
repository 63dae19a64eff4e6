//! Where each particle was a frame before (§7 for particles): a simulation that keeps its
//! particles — by `id`, or in the same order every frame — tells the liquid's motion over
//! the frame exactly at every particle, displacement included, where its saved velocities
//! only give the rate at both ends.

use glam::Vec3;
use hashbrown::HashMap;
use rayon::prelude::*;

use super::Particles;

/// Each particle of `now` with its mean velocity over the `duration` seconds since
/// `before`: its displacement divided by `duration`. Particles are matched by id when
/// both frames carry ids (a particle new in `now` takes its own velocity, scaled by
/// `scale`, or none); else by index when both hold as many particles and the order is
/// plainly kept ([`Motion::coherent`]). `None` when the frames cannot be matched, or when
/// what moved them is their jitter rather than the liquid's motion ([`Motion::carries`]).
/// Where the liquid at large holds still but some particles travel well past its jitter
/// (spray over a pool at rest), those are carried and the others held.
pub fn frame_velocities(
    before: &Particles,
    now: &Particles,
    duration: f32,
    scale: Option<f32>,
    h: f32,
) -> Option<Vec<Vec3>> {
    if duration.is_nan() || duration <= 0.0 || now.positions.is_empty() {
        return None;
    }
    let own = |i: usize| -> Vec3 {
        match (&now.velocities, scale) {
            (Some(v), Some(k)) => v[i] * k * duration,
            _ => Vec3::ZERO,
        }
    };
    let (moved, by_id) = if let (Some(ids_before), Some(ids_now)) = (&before.ids, &now.ids) {
        let at: HashMap<i64, usize> = ids_before
            .iter()
            .enumerate()
            .map(|(i, &id)| (id, i))
            .collect();
        if at.len() != ids_before.len() {
            return None; // ids that repeat identify nothing
        }
        let moved: Vec<Vec3> = ids_now
            .iter()
            .enumerate()
            .map(|(i, id)| match at.get(id) {
                Some(&j) => now.positions[i] - before.positions[j],
                None => own(i),
            })
            .collect();
        (moved, true)
    } else {
        if before.positions.len() != now.positions.len() {
            return None;
        }
        let moved: Vec<Vec3> = now
            .positions
            .iter()
            .zip(&before.positions)
            .map(|(a, b)| *a - *b)
            .collect();
        (moved, false)
    };
    let motion = assess(&now.positions, &moved, h);
    if !(by_id || motion.coherent) {
        return None;
    }
    if motion.carries() {
        return Some(moved.into_iter().map(|d| d / duration).collect());
    }
    // The liquid at large holds still, but part of it may travel: spray over a pool at
    // rest, a drop falling into it. That part is carried; the rest, whose jitter the
    // attraction filters, holds still.
    let still = motion.still();
    if !moved.iter().any(|d| d.length() >= 2.0 * still) {
        return None;
    }
    Some(
        moved
            .into_iter()
            .map(|d| d * travelling(d.length(), still) / duration)
            .collect(),
    )
}

/// How much of a displacement of `length` is carried over a liquid whose displacements
/// up to `still` are its jitter: none up to `still`, all from twice that, smooth between
/// (a particle does not jump from held to carried from one frame to the next).
fn travelling(length: f32, still: f32) -> f32 {
    if still <= 0.0 {
        return 1.0;
    }
    let t = (length / still - 1.0).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// How the particles moved over a frame, from neighbour pairs (each particle and the next
/// one filed in its cell of side `h`, within `h` of each other).
struct Motion {
    /// Neighbours moved alike (within `h`) for 98 % of the pairs: a liquid's motion of any
    /// speed or acceleration, not a reordering (a solver that sorts its particles), whose
    /// displacements are unrelated from particle to particle.
    coherent: bool,
    /// Median displacement.
    travel: f32,
    /// Median difference between neighbours' displacements: the particles' own jitter
    /// (and the shear across a support).
    scatter: f32,
}

impl Motion {
    /// Whether the motion carries the skin: the liquid travels more than three times its
    /// particles' scatter. A fluid at rest whose particles jitter has no motion to carry —
    /// carried by the jitter, a jittered ball at rest flickered 0.045–0.076 voxel a frame
    /// against 0.009 by attraction alone, the filtering the skin is for.
    fn carries(&self) -> bool {
        self.travel > self.still()
    }

    /// The displacement a particle's jitter reaches: three times the scatter.
    fn still(&self) -> f32 {
        3.0 * self.scatter
    }
}

fn assess(positions: &[Vec3], moved: &[Vec3], h: f32) -> Motion {
    let mut filed: Vec<(glam::IVec3, u32)> = positions
        .par_iter()
        .enumerate()
        .map(|(i, p)| ((*p / h).floor().as_ivec3(), i as u32))
        .collect();
    filed.par_sort_unstable_by_key(|(c, i)| (c.to_array(), *i));
    let mut differences: Vec<f32> = filed
        .windows(2)
        .filter_map(|pair| {
            let ((a, i), (b, j)) = (pair[0], pair[1]);
            let (i, j) = (i as usize, j as usize);
            (a == b && positions[i].distance(positions[j]) <= h)
                .then(|| moved[i].distance(moved[j]))
        })
        .collect();
    let pairs = differences.len();
    let alike = differences.iter().filter(|&&d| d <= h).count();
    let median = |v: &mut Vec<f32>| -> f32 {
        if v.is_empty() {
            return 0.0;
        }
        let k = v.len() / 2;
        *v.select_nth_unstable_by(k, f32::total_cmp).1
    };
    let mut travel: Vec<f32> = moved.iter().map(|d| d.length()).collect();
    Motion {
        coherent: pairs > 0 && alike * 50 >= pairs * 49,
        travel: median(&mut travel),
        scatter: median(&mut differences),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cloud(
        positions: Vec<Vec3>,
        velocities: Option<Vec<Vec3>>,
        ids: Option<Vec<i64>>,
    ) -> Particles {
        Particles {
            positions,
            velocities,
            ids,
            ..Particles::default()
        }
    }

    #[test]
    fn ids_match_particles_whatever_their_order() {
        let before = cloud(vec![Vec3::ZERO, Vec3::X], None, Some(vec![7, 3]));
        // Reordered, moved, and one particle new (it takes its own velocity).
        let now = cloud(
            vec![Vec3::new(1.0, 0.5, 0.0), Vec3::new(0.0, 0.25, 0.0), Vec3::Z],
            Some(vec![Vec3::ZERO, Vec3::ZERO, Vec3::Y]),
            Some(vec![3, 7, 9]),
        );
        let u = frame_velocities(&before, &now, 0.5, Some(2.0), 0.1).unwrap();
        assert_eq!(
            u,
            vec![
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(0.0, 0.5, 0.0),
                Vec3::Y * 2.0
            ]
        );
        // Repeated ids identify nothing.
        let twice = cloud(vec![Vec3::ZERO, Vec3::X], None, Some(vec![1, 1]));
        assert!(frame_velocities(&twice, &now, 0.5, None, 0.1).is_none());
    }

    #[test]
    fn order_is_trusted_only_when_the_motion_says_so() {
        // A block of 10³ particles, spacing 0.1.
        let positions: Vec<Vec3> = (0..1000)
            .map(|i| Vec3::new((i / 100) as f32, (i / 10 % 10) as f32, (i % 10) as f32) * 0.1)
            .collect();
        let before = cloud(positions.clone(), None, None);
        let h = 0.2;
        // A fast motion, sheared and accelerating: kept, the displacement per second,
        // whatever velocities the files say.
        let moved: Vec<Vec3> = positions
            .iter()
            .map(|p| *p + Vec3::new(3.0 + 0.5 * p.z, 0.0, -2.0 * p.x * p.x))
            .collect();
        let now = cloud(moved.clone(), Some(vec![Vec3::ZERO; 1000]), None);
        let u = frame_velocities(&before, &now, 0.25, Some(1.0), h).unwrap();
        assert!((u[999] - (moved[999] - positions[999]) / 0.25).length() < 1e-4);
        // The same particles reordered (a solver that sorts them): not trusted.
        let mut shuffled = moved.clone();
        shuffled.reverse();
        assert!(frame_velocities(&before, &cloud(shuffled, None, None), 0.25, None, h).is_none());
        let mut rotated = moved.clone();
        rotated.rotate_left(37);
        assert!(frame_velocities(&before, &cloud(rotated, None, None), 0.25, None, h).is_none());
        // Different counts without ids: nothing to match.
        let fewer = cloud(moved[1..].to_vec(), None, None);
        assert!(frame_velocities(&before, &fewer, 0.25, None, h).is_none());
    }

    #[test]
    fn jitter_is_not_a_motion_to_carry() {
        let positions: Vec<Vec3> = (0..1000)
            .map(|i| Vec3::new((i / 100) as f32, (i / 10 % 10) as f32, (i % 10) as f32) * 0.1)
            .collect();
        let mut state = 7u64;
        let mut jitter = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 0.015
        };
        let before = cloud(positions.clone(), None, None);
        let at_rest: Vec<Vec3> = positions
            .iter()
            .map(|p| *p + Vec3::new(jitter(), jitter(), jitter()))
            .collect();
        let h = 0.2;
        // A fluid at rest whose particles jitter: nothing to carry, by order or by id.
        assert!(
            frame_velocities(&before, &cloud(at_rest.clone(), None, None), 0.25, None, h).is_none()
        );
        let ids: Vec<i64> = (0..1000).collect();
        let before_ids = cloud(positions.clone(), None, Some(ids.clone()));
        let now_ids = cloud(at_rest.clone(), None, Some(ids));
        assert!(frame_velocities(&before_ids, &now_ids, 0.25, None, h).is_none());
        // The same jitter on a drift ten times larger: carried.
        let drifting: Vec<Vec3> = at_rest.iter().map(|p| *p + Vec3::X * 0.1).collect();
        assert!(frame_velocities(&before, &cloud(drifting, None, None), 0.25, None, h).is_some());
        // The pool at rest, jittering, and a drop of a few particles flying past: the drop
        // carried, the pool held.
        let mut splashed = at_rest.clone();
        for p in &mut splashed[995..] {
            *p += Vec3::X * 0.1;
        }
        let u = frame_velocities(&before, &cloud(splashed.clone(), None, None), 0.25, None, h)
            .expect("the drop is carried");
        for (i, v) in u.iter().enumerate() {
            match i >= 995 {
                true => assert!((*v - (splashed[i] - positions[i]) / 0.25).length() < 1e-4),
                false => assert_eq!(*v, Vec3::ZERO, "particle {i} jitters"),
            }
        }
    }
}
