//! Where each particle was a frame before (§7 for particles): a simulation that keeps its
//! particles — by `id`, or in the same order every frame — tells the liquid's motion over
//! the frame exactly at every particle, displacement included, where its saved velocities
//! only give the rate at both ends.

use glam::Vec3;
use hashbrown::HashMap;

use super::Particles;

/// Each particle of `now` with its mean velocity over the `duration` seconds since
/// `before`: its displacement divided by `duration`. Particles are matched by id when
/// both frames carry ids (a particle new in `now` takes its own velocity, scaled by
/// `scale`, or none); else by index when both hold as many particles and the order is
/// plainly kept ([`coherent`]). `None` when the frames cannot be matched.
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
            (Some(v), Some(k)) => v[i] * k,
            _ => Vec3::ZERO,
        }
    };
    if let (Some(ids_before), Some(ids_now)) = (&before.ids, &now.ids) {
        let at: HashMap<i64, usize> = ids_before
            .iter()
            .enumerate()
            .map(|(i, &id)| (id, i))
            .collect();
        if at.len() != ids_before.len() {
            return None; // ids that repeat identify nothing
        }
        return Some(
            ids_now
                .iter()
                .enumerate()
                .map(|(i, id)| match at.get(id) {
                    Some(&j) => (now.positions[i] - before.positions[j]) / duration,
                    None => own(i),
                })
                .collect(),
        );
    }
    if before.positions.len() != now.positions.len() {
        return None;
    }
    let moved: Vec<Vec3> = now
        .positions
        .iter()
        .zip(&before.positions)
        .map(|(a, b)| *a - *b)
        .collect();
    let kept = coherent(&now.positions, &moved, h);
    kept.then(|| moved.into_iter().map(|d| d / duration).collect())
}

/// Whether displacements matched by index are a liquid's motion rather than a reordering
/// (a solver that sorts its particles): particles within `h` of each other now moved
/// alike, within `h`, for 98 % of the pairs checked (each particle and the next one
/// filed in its cell of side `h`). A motion of any speed or acceleration passes; a
/// shuffle, whose displacements are unrelated from particle to particle, does not.
fn coherent(positions: &[Vec3], moved: &[Vec3], h: f32) -> bool {
    let mut filed: Vec<(glam::IVec3, u32)> = positions
        .iter()
        .enumerate()
        .map(|(i, p)| ((*p / h).floor().as_ivec3(), i as u32))
        .collect();
    filed.sort_unstable_by_key(|(c, i)| (c.to_array(), *i));
    let (mut pairs, mut alike) = (0usize, 0usize);
    for pair in filed.windows(2) {
        let ((a, i), (b, j)) = (pair[0], pair[1]);
        let (i, j) = (i as usize, j as usize);
        if a != b || positions[i].distance(positions[j]) > h {
            continue;
        }
        pairs += 1;
        if moved[i].distance(moved[j]) <= h {
            alike += 1;
        }
    }
    pairs > 0 && alike * 50 >= pairs * 49
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
            radii: None,
            velocities,
            ids,
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
}
