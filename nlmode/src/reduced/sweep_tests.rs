//! Tests of [`super`]: the channel tabulation along the sweep and the sweep kernel.
use super::*;
use crate::attachment::{LinearAttachment, ShakerParams};
use crate::nma::ModalTable;

/// An interface model that only knows `condense` (the trait's default
/// derivative by central differences).
#[derive(Debug)]
struct ValuesOnly(crate::reduced::PreparedAttachment);

impl crate::reduced::InterfaceModel for ValuesOnly {
    fn name(&self) -> &str {
        self.0.name()
    }
    fn interface_points(&self) -> Vec<String> {
        self.0.interface_points()
    }
    fn ninput(&self) -> usize {
        self.0.ninput()
    }
    fn condense(
        &self,
        omega_rad_s: f64,
    ) -> Result<crate::reduced::Condensed, crate::reduced::AttachmentModelError> {
        self.0.condense(omega_rad_s)
    }
}

#[test]
fn default_channel_derivative_agrees_with_the_exact_one() {
    use crate::reduced::InterfaceModel;
    let shaker = LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3").unwrap();
    let exact = crate::reduced::PreparedAttachment::new(shaker.clone()).unwrap();
    let fd = ValuesOnly(crate::reduced::PreparedAttachment::new(shaker).unwrap());
    for w in [120.0, 356.0, 700.0] {
        let ((z, t), (dz, dt)) = exact.condense_with_derivative(w).unwrap();
        let ((zf, tf), (dzf, dtf)) = fd.condense_with_derivative(w).unwrap();
        assert_eq!((z, t), (zf, tf));
        let e = (&dz - &dzf).norm() / dz.norm();
        // truncation error of the central difference, largest near the
        // shaker's suspension resonance
        assert!(e < 2e-7, "{w}: {e:e}");
        assert!((&dt - &dtf).norm() < 2e-7 * dt.norm(), "{w}");
    }
}

/// A sink sees the stored result's samples, in order, in bounded batches,
/// also for a sweep that leaves the table (the stop sample last).
#[test]
fn the_sink_receives_the_stored_samples() {
    struct Batches(Vec<SlowFlowSample>, usize);
    impl SweepSink for Batches {
        fn samples(&mut self, b: &[SlowFlowSample]) -> Result<(), ReducedError> {
            assert!(!b.is_empty() && b.len() <= SWEEP_BATCH);
            self.0.extend_from_slice(b);
            self.1 += 1;
            Ok(())
        }
    }
    let m = linear_model_with_the_paper_shaker();
    let opts = SlowFlowOptions {
        output_samples: 2501,
        ..Default::default()
    };
    for volts in [1.0, 1e4] {
        let sweep = LinearSweep::new(300.0, 420.0, 400.0, volts).unwrap();
        let stored = m.simulate_sweep(&sweep, &opts).unwrap();
        let mut sink = Batches(Vec::new(), 0);
        let zero = Complex64::new(0.0, 0.0);
        let run = m
            .simulate_sweep_into(&sweep, &opts, zero, &mut sink)
            .unwrap();
        assert_eq!(sink.0, stored.samples, "{volts} V");
        // an envelope-only sink: the same envelope, bit for bit
        struct EnvelopeOnly(Vec<SlowFlowSample>);
        impl SweepSink for EnvelopeOnly {
            fn samples(&mut self, b: &[SlowFlowSample]) -> Result<(), ReducedError> {
                self.0.extend_from_slice(b);
                Ok(())
            }
            fn fields(&self) -> SampleFields {
                SampleFields::Envelope
            }
        }
        let mut env = EnvelopeOnly(Vec::new());
        m.simulate_sweep_into(&sweep, &opts, zero, &mut env)
            .unwrap();
        assert_eq!(env.0.len(), stored.samples.len());
        for (e, s) in env.0.iter().zip(&stored.samples) {
            assert_eq!(
                (e.t_s, e.omega_rad_s, e.a, e.amplitude),
                (s.t_s, s.omega_rad_s, s.a, s.amplitude)
            );
            assert_eq!(
                (e.tip_amplitude_m, e.force_amplitude_n, e.force_n),
                (s.tip_amplitude_m, s.force_amplitude_n, s.force_n)
            );
            assert!(e.modal_frequency_rad_s.is_nan() && e.drive_amplitude_m.is_nan());
        }
        assert_eq!(run.samples, stored.samples.len());
        assert_eq!(run.status, stored.status);
        // folded as computed: the same three quantities, bit for bit
        struct Triples(Vec<[u64; 3]>);
        impl EnvelopeFold for Triples {
            fn fold<B: EnvelopeBatch>(&mut self, b: B) -> Result<(), ReducedError> {
                b.each(|x, y, f| self.0.push([x.to_bits(), y.to_bits(), f.to_bits()]))
            }
        }
        let mut folded = Triples(Vec::new());
        let frun = m
            .simulate_sweep_folded(&sweep, &opts, zero, &mut folded)
            .unwrap();
        let bits = |s: &SlowFlowSample| {
            let q = [s.omega_rad_s, s.tip_amplitude_m, s.force_amplitude_n];
            q.map(f64::to_bits)
        };
        assert_eq!(
            folded.0,
            stored.samples.iter().map(bits).collect::<Vec<_>>()
        );
        assert_eq!((frun.samples, frun.status), (run.samples, run.status));
        assert!(sink.1 >= stored.samples.len().div_ceil(SWEEP_BATCH));
        if volts > 1e3 {
            assert!(
                matches!(run.status, SweepStatus::LeftTableRange { .. }),
                "{:?}",
                run.status
            );
        }
    }
}

/// A linear mode (omega0 = 356.2 rad/s, D = 0.4 %, tip and 2l/3 shapes)
/// driven by the paper's shaker at 2l/3 (the channels depend on Omega only).
fn linear_model_with_the_paper_shaker() -> ReducedModel {
    let table = ModalTable::linear(
        356.2,
        0.004,
        &[
            ("tip", Complex64::new(1.5, 0.0)),
            ("2l3", Complex64::new(1.0, 0.0)),
        ],
        1e-6,
        1e-2,
    );
    let shaker = LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3").unwrap();
    ReducedModel::new(&table, "tip", "2l3")
        .unwrap()
        .with_linear_attachment(&shaker, &[Complex64::new(1.0, 0.0)])
        .unwrap()
}

#[test]
fn channel_cache_matches_the_attachment_model() {
    // the paper's shaker at 2l/3 (a linear table: the channels depend on
    // Omega only); its quantities vary by orders of magnitude over the range
    let m = linear_model_with_the_paper_shaker();
    let (lo, hi, u) = (100.0, 900.0, 7.0);
    let tol = 1e-9;
    let cache = OmegaCache::build(&m, lo, hi, u, tol).unwrap();
    let mut got = vec![Complex64::new(0.0, 0.0); m.nch];
    let mut exact = got.clone();
    let mut scale = vec![0.0f64; m.nch];
    for j in 0..=64 {
        m.fill_channels(lo + (hi - lo) * j as f64 / 64.0, u, &mut exact)
            .unwrap();
        for (s, e) in scale.iter_mut().zip(&exact) {
            *s = s.max(e.norm());
        }
    }
    let mut worst: f64 = 0.0;
    // scattered points, in both directions (the segment hint must not matter)
    for j in 0..3000 {
        let x = ((j * 7919) % 3001) as f64 / 3000.0;
        let w = lo + (hi - lo) * x;
        cache.eval(w, &mut got);
        m.fill_channels(w, u, &mut exact).unwrap();
        for c in 0..m.nch {
            worst = worst.max((got[c] - exact[c]).norm() / scale[c]);
        }
    }
    // the refinement bounds the midpoint error by tol; between midpoints and
    // nodes the cubic Hermite error is of the same size
    assert!(worst < 4.0 * tol, "{worst:e} with {} nodes", cache.len());
    // exact at the nodes and clamped outside
    cache.eval(lo, &mut got);
    m.fill_channels(lo, u, &mut exact).unwrap();
    assert_eq!(got, exact);
    cache.eval(0.5 * lo, &mut got);
    assert_eq!(got, exact);
}
