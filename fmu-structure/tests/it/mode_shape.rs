//! The FMI 3.0 mode shape arrays `mode_shape_re`, `mode_shape_im` (one
//! entry per point of the modal table, sized by the UInt64 structural
//! parameter `mode_shape_points`): values, `nValues` counting, Configuration
//! Mode, and a table whose point count differs from the parameter.
use fmi2_export::testing3::*;
use fmi2_export::types::Component;
use fmi2_export::{ffi, fmi3, Status};
use nlmode::nma::ModalTable;
use nlmode::Complex64;
use structure::{vr, Structure};

use crate::model::nonlinear_table;

fn get(c: Component, vrs: &[u32], nv: usize) -> (Status, Vec<f64>) {
    let mut v = vec![f64::NAN; nv];
    let s =
        unsafe { fmi3::get_float64::<Structure>(c, vrs.as_ptr(), vrs.len(), v.as_mut_ptr(), nv) };
    (s, v)
}

fn set_points(c: Component, n: u64) -> Status {
    unsafe { fmi3::set_uint64::<Structure>(c, &vr::MODE_SHAPE_POINTS, 1, &n, 1) }
}

fn points(c: Component) -> u64 {
    let mut n = 0;
    assert_eq!(
        unsafe { fmi3::get_uint64::<Structure>(c, &vr::MODE_SHAPE_POINTS, 1, &mut n, 1) },
        Status::Ok
    );
    n
}

/// The arrays after some forced steps are `a phi_1,k(a) / g(a)` of the
/// table (its PCHIP interpolant at the output amplitude `a`, the gauge `g`
/// of the drive point `2l3`), read together with scalars in one call.
#[test]
fn mode_shape_is_the_tables_fundamental_at_the_output_amplitude() {
    let d = tempfile::tempdir().unwrap();
    let path = nonlinear_table(d.path());
    let c = instantiate3_early::<Structure>(Some(d.path()), false).unwrap();
    assert_eq!(points(c), 3, "start value in Instantiated");
    initialize3::<Structure>(c, &[(vr::F, 30.0)]).unwrap();
    let mut t = 0.0;
    for _ in 0..400 {
        let (s, _, last) = do_step3::<Structure>(c, t, 1e-4);
        assert_eq!(s, Status::Ok);
        t = last;
    }
    let vrs = [vr::X, vr::MODE_SHAPE_RE, vr::A, vr::MODE_SHAPE_IM];
    let (s, v) = get(c, &vrs, 8);
    assert_eq!(s, Status::Ok);
    let (x, re, a, im) = (v[0], &v[1..4], v[4], &v[5..8]);
    assert!(a > 1e-4, "a = {a}: inside the nonlinear part of the table");
    assert_eq!(x, get_float64::<Structure>(c, &[vr::X]).unwrap()[0]);
    let table = ModalTable::read(&path).unwrap().interpolator().unwrap();
    let g = table
        .shape(table.point_index("2l3").unwrap(), 1, a)
        .unwrap();
    let g = g / g.norm();
    let mut worst = 0.0f64;
    for (k, name) in ["tip", "l3", "2l3"].iter().enumerate() {
        let q = a * table.shape(table.point_index(name).unwrap(), 1, a).unwrap() / g;
        let got = Complex64::new(re[k], im[k]);
        worst = worst.max((got - q).norm() / q.norm());
    }
    assert!(worst < 1e-14, "relative error {worst:e}");
    // the drive point's is real and positive (the gauge)
    assert!(re[2] > 0.0 && im[2].abs() < 1e-15 * re[2]);
    // nValues is the sum of the sizes: anything else is refused unwritten
    let (s, v) = get(c, &vrs, 4);
    assert_eq!(s, Status::Error);
    assert!(v.iter().all(|x| x.is_nan()));
    unsafe { ffi::free_instance::<Structure>(c) };
}

/// A table of 4 points with the default `mode_shape_points = 3` is an
/// error naming both numbers; set to 4 in Configuration Mode it reads.
#[test]
fn a_table_of_another_size_needs_the_structural_parameter() {
    let d = tempfile::tempdir().unwrap();
    let one = Complex64::new(1.0, 0.0);
    let t = ModalTable::linear(
        100.0,
        0.01,
        &[
            ("tip", one),
            ("2l3", one * 0.5),
            ("l3", one * 0.2),
            ("root", one * 0.01),
        ],
        1e-9,
        1e-3,
    );
    t.write(&d.path().join("modal_table.json")).unwrap();
    let c = instantiate3_early::<Structure>(Some(d.path()), false).unwrap();
    initialize3::<Structure>(c, &[]).unwrap();
    take_logged();
    let (s, _) = get(c, &[vr::MODE_SHAPE_RE], 3);
    assert_eq!(s, Status::Error);
    let log = take_logged().join("\n");
    assert!(
        log.contains("has 4 points") && log.contains("mode_shape_points = 3"),
        "{log}"
    );
    unsafe { ffi::free_instance::<Structure>(c) };

    let c = instantiate3_early::<Structure>(Some(d.path()), false).unwrap();
    // outside Configuration Mode the structural parameter is refused
    assert_eq!(set_points(c, 4), Status::Error);
    unsafe { ffi::reset::<Structure>(c) };
    assert_eq!(
        unsafe { fmi3::enter_configuration_mode::<Structure>(c) },
        Status::Ok
    );
    assert_eq!(set_points(c, 0), Status::Error, "0 is below min = 1");
    unsafe { ffi::reset::<Structure>(c) };
    assert_eq!(
        unsafe { fmi3::enter_configuration_mode::<Structure>(c) },
        Status::Ok
    );
    assert_eq!(set_points(c, 4), Status::Ok);
    assert_eq!(
        unsafe { fmi3::exit_configuration_mode::<Structure>(c) },
        Status::Ok
    );
    assert_eq!(points(c), 4);
    initialize3::<Structure>(c, &[(vr::F, 1.0)]).unwrap();
    let (s, _, _) = do_step3::<Structure>(c, 0.0, 1e-2);
    assert_eq!(s, Status::Ok);
    let (s, v) = get(c, &[vr::MODE_SHAPE_RE, vr::MODE_SHAPE_IM], 8);
    assert_eq!(s, Status::Ok);
    let a = get_float64::<Structure>(c, &[vr::A]).unwrap()[0];
    let expect = [1.0, 0.5, 0.2, 0.01].map(|r| r * a);
    for (k, e) in expect.iter().enumerate() {
        assert!(
            (v[k] - e).abs() <= 1e-15 * a && v[4 + k] == 0.0,
            "{v:?} vs {expect:?}"
        );
    }
    // no Configuration Mode once initialized (fixed structural parameter)
    assert_eq!(
        unsafe { fmi3::enter_configuration_mode::<Structure>(c) },
        Status::Error
    );
    unsafe { ffi::free_instance::<Structure>(c) };
}
