//! [`Scratch`]: the working vectors of the hierarchy walks (the separation band's walk, the
//! out-of-reach proof's walk, and the relevant-plane queries both make), handed to the walks
//! by whoever owns them instead of kept in thread-locals. A running simulation keeps one per
//! pair thread in its carried pair data ([`PairCarry::pairs_and_scratch`](super::PairCarry::pairs_and_scratch)), so
//! that the walks allocate nothing once the vectors have grown; a one-off evaluation makes its
//! own. What a walk leaves in it never changes a result: every walk clears what it reads
//! before reading it, and a stale nearest-point hint only changes where a search starts
//! (`tests`: any hint gives the same relevant set).

use super::band::BandWalk;
use super::reach::ReachWalk;
use crate::geometry::ssdf::Relevant;

/// Scratch space of the hierarchy walks, for one thread at a time (module documentation).
/// Cloning gives empty scratch: its contents are never worth copying.
#[derive(Default)]
pub struct Scratch {
    /// The separation band's walk ([`band_of`](super::band_of)).
    pub(super) band: BandWalk,
    /// The out-of-reach proof's walk ([`cloud_beyond`](super::cloud_beyond)).
    pub(super) reach: ReachWalk,
    /// The relevant planes of one query point at a time (the band's entries, the forces of
    /// the entries whose terms the band did not keep, and the proof's points whose SSDF or
    /// springs it sums).
    pub(crate) relevant: Relevant,
}

impl Clone for Scratch {
    fn clone(&self) -> Self {
        Scratch::default()
    }
}

impl std::fmt::Debug for Scratch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Scratch")
    }
}
