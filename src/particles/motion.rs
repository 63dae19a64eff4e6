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
/// plainly kept: the displacements agree with the saved velocities (90 % of the
/// particles within half their own velocity's step plus `h`), or, without velocities,
/// half of the particles moved less than 2·`h`. `None` when the frames cannot be matched.
pub fn frame_velocities(
    before: &Particles,
    now: &Particles,
    duration: f32,
    scale: Option<f32>,
    h: f32,
) -> Option<Vec<Vec3>> {
    if !(duration > 0.0) || now.positions.is_empty() {
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
    let kept = match (&now.velocities, scale) {
        (Some(v), Some(k)) => {
            let agree = moved
                .iter()
                .zip(v)
                .filter(|(d, v)| {
                    let step = **v * (k * duration);
                    (**d - step).length() <= 0.5 * step.length() + h
                })
                .count();
            agree * 10 >= moved.len() * 9
        }
        _ => {
            let near = moved.iter().filter(|d| d.length() < 2.0 * h).count();
            near * 2 >= moved.len()
        }
    };
    kept.then(|| moved.into_iter().map(|d| d / duration).collect())
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
        let n = 100;
        let positions: Vec<Vec3> = (0..n)
            .map(|i| Vec3::new(i as f32 * 0.1, 0.0, 0.0))
            .collect();
        let velocity = Vec3::new(0.0, 4.0, 0.0);
        let before = cloud(positions.clone(), Some(vec![velocity; n]), None);
        let moved: Vec<Vec3> = positions.iter().map(|p| *p + velocity * 0.25).collect();
        let now = cloud(moved.clone(), Some(vec![velocity; n]), None);
        // A fast motion the velocities explain: kept, the displacement per second.
        let u = frame_velocities(&before, &now, 0.25, Some(1.0), 0.05).unwrap();
        assert!(u.iter().all(|v| (*v - velocity).length() < 1e-4));
        // Velocities in other units (a scale not given): not trusted.
        assert!(frame_velocities(&before, &now, 0.25, Some(100.0), 0.05).is_none());
        // The same particles shuffled (a solver that sorts them): not trusted.
        let mut shuffled = moved.clone();
        shuffled.reverse();
        let now = cloud(shuffled, Some(vec![velocity; n]), None);
        assert!(frame_velocities(&before, &now, 0.25, Some(1.0), 0.05).is_none());
        // Without velocities: small motions are trusted, large ones not.
        let slow = cloud(
            positions.iter().map(|p| *p + Vec3::Y * 0.01).collect(),
            None,
            None,
        );
        assert!(frame_velocities(&before, &slow, 0.25, None, 0.05).is_some());
        let fast = cloud(moved, None, None);
        assert!(frame_velocities(&before, &fast, 0.25, None, 0.05).is_none());
        // Different counts without ids: nothing to match.
        let fewer = cloud(positions[1..].to_vec(), None, None);
        assert!(frame_velocities(&before, &fewer, 0.25, None, 0.05).is_none());
    }
}
