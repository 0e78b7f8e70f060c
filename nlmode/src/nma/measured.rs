//! Modal tables from measured nonlinear modal data.
use super::errors::NmaError;
use crate::table::{ModalTable, PointShape, MODAL_TABLE_FORMAT, MODAL_TABLE_VERSION};

/// A modal table from measured nonlinear modal data (e.g. phase-resonant
/// testing), as the paper suggests at the end of Section 3.2.
///
/// CSV with a header row; `#` starts a comment line. Columns (any order, names
/// case-insensitive): `a` or `amplitude` [sqrt(kg) m], `omega` or `omega_rad_s`
/// [rad/s], `D` or `damping_ratio` [-], and the drive-point shape
/// `phi_re`/`phi_im` or `<point>_re`/`<point>_im` (fundamental harmonic
/// `phi_1` at `point_name`). Rows must have strictly increasing `a > 0`.
/// The table has `H = 1` and `phi_0 = 0` (not measured).
pub fn table_from_measured_csv(text: &str, point_name: &str) -> Result<ModalTable, NmaError> {
    let err = |line: usize, message: String| NmaError::MeasuredData { line, message };
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let (hline, header) = lines.next().ok_or_else(|| err(0, "no header row".into()))?;
    let cols: Vec<String> = header
        .split(',')
        .map(|c| c.trim().to_ascii_lowercase())
        .collect();
    let pn = point_name.to_ascii_lowercase();
    let find = |names: &[&str]| -> Result<usize, NmaError> {
        cols.iter()
            .position(|c| names.contains(&c.as_str()))
            .ok_or_else(|| {
                err(
                    hline,
                    format!("missing column {} (header: {header})", names.join(" or ")),
                )
            })
    };
    let re_name = format!("{pn}_re");
    let im_name = format!("{pn}_im");
    let ia = find(&["a", "amplitude"])?;
    let io = find(&["omega", "omega_rad_s"])?;
    let id = find(&["d", "damping_ratio"])?;
    let ir = find(&["phi_re", &re_name])?;
    let ii = find(&["phi_im", &im_name])?;
    let mut t = ModalTable {
        format: MODAL_TABLE_FORMAT.to_string(),
        version: MODAL_TABLE_VERSION,
        description: format!("measured nonlinear modal data, drive point '{point_name}'"),
        harmonics: 1,
        amplitude: vec![],
        omega_rad_s: vec![],
        damping_ratio: vec![],
        points: vec![PointShape {
            name: point_name.to_string(),
            re: vec![],
            im: vec![],
        }],
        coordinates: vec![],
        truncated_at_fold: None,
        accuracy: None,
        linear_modes: None,
    };
    for (ln, line) in lines {
        let vals: Vec<&str> = line.split(',').map(|v| v.trim()).collect();
        if vals.len() != cols.len() {
            return Err(err(
                ln,
                format!("{} fields, the header has {}", vals.len(), cols.len()),
            ));
        }
        let get = |i: usize| -> Result<f64, NmaError> {
            let v: f64 = vals[i].parse().map_err(|_| {
                err(
                    ln,
                    format!("'{}' in column '{}' is not a number", vals[i], cols[i]),
                )
            })?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(err(
                    ln,
                    format!("non-finite value {v} in column '{}'", cols[i]),
                ))
            }
        };
        let (a, om, d, re, im) = (get(ia)?, get(io)?, get(id)?, get(ir)?, get(ii)?);
        if a <= 0.0 {
            return Err(err(ln, format!("amplitude a = {a} must be positive")));
        }
        if let Some(&prev) = t.amplitude.last() {
            if a <= prev {
                return Err(err(
                    ln,
                    format!("amplitude a = {a} is not larger than the previous {prev}"),
                ));
            }
        }
        if om <= 0.0 {
            return Err(err(
                ln,
                format!("modal frequency omega = {om} rad/s must be positive"),
            ));
        }
        t.amplitude.push(a);
        t.omega_rad_s.push(om);
        t.damping_ratio.push(d);
        t.points[0].re.push(vec![0.0, re]);
        t.points[0].im.push(vec![0.0, im]);
    }
    if t.amplitude.len() < 2 {
        return Err(err(
            hline,
            format!("need at least 2 data rows, got {}", t.amplitude.len()),
        ));
    }
    Ok(t)
}
