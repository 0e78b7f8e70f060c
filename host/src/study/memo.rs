//! An attachment model that remembers its condensed quantities by frequency.
//!
//! Each sweep tabulates `Z_G(Omega)`, `T_G(Omega)` of its attachments over
//! its frequency range (`nlmode::reduced`'s channel table: nodes bisected
//! until the cubic Hermite interpolant meets its tolerance), at the same
//! frequencies for every sample of a study group (the range and the
//! attachments are the group's; the refinement's decisions scale with the
//! voltage). The condensation (`eq:fc1`, matrix algebra on the heap) was
//! 0.15 M instructions of a case-(a) sample; [`Memo`] computes it once per
//! frequency and hands out copies of the same numbers after that, so the
//! tables stay bit-identical to those of a sweep without it.
use nlmode::reduced::{AttachmentModelError, Condensed, InterfaceModel};
use std::collections::HashMap;
use std::sync::RwLock;

/// Frequencies a [`Memo`] keeps per kind (values; values with derivatives):
/// a sweep's table has tens of nodes, a group a few such tables; beyond
/// this the quantities are computed and not kept (bounded memory).
pub const MAX_KEPT: usize = 4096;

/// `inner` with its `condense` and `condense_with_derivative` results kept by
/// the bits of `Omega`.
#[derive(Debug)]
pub struct Memo<M> {
    inner: M,
    values: RwLock<HashMap<u64, Condensed>>,
    derivatives: RwLock<HashMap<u64, (Condensed, Condensed)>>,
}

impl<M: InterfaceModel> Memo<M> {
    pub fn new(inner: M) -> Self {
        Self {
            inner,
            values: RwLock::default(),
            derivatives: RwLock::default(),
        }
    }
}

/// The value kept for `key`, else `compute`d (and kept while there is room).
fn kept<T: Clone>(
    map: &RwLock<HashMap<u64, T>>,
    key: u64,
    compute: impl FnOnce() -> Result<T, AttachmentModelError>,
) -> Result<T, AttachmentModelError> {
    if let Some(v) = map.read().unwrap_or_else(|e| e.into_inner()).get(&key) {
        return Ok(v.clone());
    }
    let v = compute()?;
    let mut m = map.write().unwrap_or_else(|e| e.into_inner());
    if m.len() < MAX_KEPT {
        m.insert(key, v.clone());
    }
    Ok(v)
}

impl<M: InterfaceModel> InterfaceModel for Memo<M> {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn interface_points(&self) -> Vec<String> {
        self.inner.interface_points()
    }
    fn ninput(&self) -> usize {
        self.inner.ninput()
    }
    fn condense(&self, omega_rad_s: f64) -> Result<Condensed, AttachmentModelError> {
        kept(&self.values, omega_rad_s.to_bits(), || {
            self.inner.condense(omega_rad_s)
        })
    }
    fn condense_with_derivative(
        &self,
        omega_rad_s: f64,
    ) -> Result<(Condensed, Condensed), AttachmentModelError> {
        kept(&self.derivatives, omega_rad_s.to_bits(), || {
            self.inner.condense_with_derivative(omega_rad_s)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nlmode::attachment::{LinearAttachment, ShakerParams};
    use nlmode::reduced::PreparedAttachment;

    #[test]
    fn the_memo_returns_the_models_numbers() {
        let shaker = LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3").unwrap();
        let plain = PreparedAttachment::new(shaker.clone()).unwrap();
        let memo = Memo::new(PreparedAttachment::new(shaker).unwrap());
        for _ in 0..2 {
            for w in [120.0, 356.2, 700.0] {
                assert_eq!(memo.condense(w).unwrap(), plain.condense(w).unwrap());
                assert_eq!(
                    memo.condense_with_derivative(w).unwrap(),
                    plain.condense_with_derivative(w).unwrap()
                );
            }
        }
        assert_eq!(memo.values.read().unwrap().len(), 3);
        assert_eq!(memo.name(), "shaker");
        assert_eq!(memo.interface_points(), vec!["2l3".to_string()]);
    }
}
