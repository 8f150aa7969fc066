//! The user's input (thesis 3.2 step 1, fig. 4.1): grabs and their targets, and the air
//! switch (the demo's button 1).

pub mod attach;
mod grab;

pub use attach::{AttachSpec, Attachment, Binding, Tether};
pub use grab::{Grab, GrabKey, GrabMotion, GrabPick, GrabSpec};

use crate::math::{Real, Soa, Vec3};

/// What the user does to the cloth.
#[derive(Clone, Debug)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Control {
    /// The grabs (the hand, F_u).
    pub grabs: Vec<Grab>,
    /// The soft attachments' particles (`[[attach]]` with `stiffness`).
    #[cfg_attr(feature = "serde", serde(default))]
    pub tethers: Vec<Tether>,
    /// Whether the pressure force acts.
    pub air_enabled: bool,
    /// Each grab's target for the step being taken (`None` while the grab is inactive).
    pub(crate) targets: Vec<Option<Vec3>>,
    /// Whether a grab holds each particle.
    pub(crate) held: Vec<bool>,
    /// Summed magnitude of the work the hands have done on the cloth since t = 0, J.
    pub(crate) hand_work: Real,
    /// Summed magnitude of the work the moving colliders have done on the cloth since t = 0, J.
    pub(crate) collider_work: Real,
    /// Summed magnitude of the work the water film's pull (the pockets model's
    /// `wet_adhesion`) has done on the cloth since t = 0, J.
    pub(crate) film_work: Real,
    /// Summed magnitude of the work the pressure force has done on the cloth since t = 0, J,
    /// as the explicit integrator measures it step by step (the thesis' force, along each
    /// particle's normal, is not exactly the gradient of the bubble's volume, so its work is
    /// not `P dV`).
    pub(crate) air_work: Real,
}

impl Control {
    /// No grabs yet for `n` particles.
    pub fn new(n: usize, air_enabled: bool) -> Self {
        Self {
            grabs: Vec::new(),
            tethers: Vec::new(),
            air_enabled,
            targets: Vec::new(),
            held: vec![false; n],
            hand_work: 0.0,
            collider_work: 0.0,
            film_work: 0.0,
            air_work: 0.0,
        }
    }

    /// Phase 1 of a step (thesis 3.2 step 1): every grab's target at `t_next` (s) given the
    /// current positions `x`, for a step of `dt` s, and which particles the hands hold during
    /// the step (every phase after this one, the air's prediction included, sees them held).
    /// An attachment's target is its point at `t_next` by `attached`.
    pub(crate) fn begin_step(
        &mut self,
        x: &Soa,
        t_next: Real,
        dt: Real,
        attached: &dyn Fn(&Attachment, Real) -> Vec3,
    ) {
        self.targets.clear();
        for g in &mut self.grabs {
            self.held[g.particle] = false;
        }
        for g in &mut self.grabs {
            let target = match &g.motion {
                GrabMotion::Attached(a) => Some(attached(a, t_next)),
                _ => g.target(t_next, x.get(g.particle), dt),
            };
            self.targets.push(target);
        }
        for (g, t) in self.grabs.iter().zip(&self.targets) {
            if t.is_some() {
                self.held[g.particle] = true;
            }
        }
        for t in &mut self.tethers {
            t.points = [
                attached(&t.attachment, t_next - dt),
                attached(&t.attachment, t_next),
            ];
        }
    }

    /// The active grabs with their targets for this step.
    pub(crate) fn active(&self) -> impl Iterator<Item = (usize, Vec3)> + '_ {
        self.grabs
            .iter()
            .zip(&self.targets)
            .filter_map(|(g, t)| t.map(|t| (g.particle, t)))
    }

    /// Summed magnitude of the work the hands have done on the cloth since t = 0, J.
    pub fn hand_work(&self) -> Real {
        self.hand_work
    }

    /// Summed magnitude of the work the moving colliders have done on the cloth since t = 0, J.
    pub fn collider_work(&self) -> Real {
        self.collider_work
    }

    /// Summed magnitude of the work the water film's pull has done on the cloth since t = 0,
    /// J (the pockets model with `[cloth] wet_adhesion`; 0 otherwise).
    pub fn film_work(&self) -> Real {
        self.film_work
    }

    /// Summed magnitude of the work the pressure force has done on the cloth since t = 0, J,
    /// where the explicit integrator measures it (0 otherwise).
    pub fn air_work(&self) -> Real {
        self.air_work
    }

    /// The work done on the cloth from outside its mechanical energy since t = 0, J: the
    /// hands', the moving colliders', the water film's and the pressure's where measured
    /// (summed magnitudes), which the energy audit allows for.
    pub fn external_work(&self) -> Real {
        self.hand_work + self.collider_work + self.film_work + self.air_work
    }

    /// Removes grab `index`, releasing its particle.
    pub(crate) fn remove(&mut self, index: usize) -> Grab {
        let g = self.grabs.remove(index);
        self.held[g.particle] = false;
        g
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.held.capacity()
            + self.targets.capacity() * std::mem::size_of::<Option<Vec3>>()
            + self.tethers.capacity() * std::mem::size_of::<Tether>()
    }
}
