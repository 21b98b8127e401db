//! What the caller gives the output-error refinement: the measured reduced data
//! ([`OeData`]: responses, forces and frequencies of every line and load case) and
//! the weight of each column ([`Weights`], [`LogTarget`]), checked before use.

use crate::error::PodidError;
use faer::c64;

/// Weight of each column (line i, load case j), in the order of the data.
#[derive(Clone, Copy)]
pub enum Weights<'a> {
    /// one scalar w_ij ≥ 0 per column: s·p values
    Scalar(&'a [f64]),
    /// one real m×m matrix T_ij per column, row-major: s·p·m·m values
    Matrix(&'a [f64]),
    /// the log-magnitude output error on measured entries (see [`LogTarget`])
    LogMagnitude(LogTarget<'a>),
}

/// The log-magnitude output error Σ_ije w_ije² (ln|y_ije| − ln|u_ije|)², y_ij = R x_ij:
/// each measured entry's dB error counts alike, whatever its level, and phase not at
/// all. Its Gauss–Newton matrix is Σ Re(J)ᵀRe(J) = ½ Re(JᴴJ) + ½ Re(JᵀJ) for the
/// complex J = ∂(ln y); the step uses the first half — the Hermitian metric
/// W_ij = ½ Rᵀ diag(w²/|y|²) R per column, re-formed at every point — which the
/// fast paths already take (the second half averages out over lines of varying
/// phase), with the exact gradient, so LM still descends the exact cost.
#[derive(Clone, Copy)]
pub struct LogTarget<'a> {
    /// R, n×m row-major (the measured entries are R x)
    pub basis: &'a [f64],
    pub n: usize,
    /// measured responses on the n entries, index ((i·p + j)·n + e)
    pub u: &'a [c64],
    /// weight w_ije ≥ 0 of each entry, same layout (0: not measured)
    pub w: &'a [f64],
}

/// Measured reduced data: s lines, p load cases, order m.
#[derive(Clone, Copy)]
pub struct OeData<'a> {
    /// angular frequency of each line (s)
    pub omega: &'a [f64],
    /// target responses u_ij, index ((i·p + j)·m + r)
    pub u: &'a [c64],
    /// forces f_ij, same layout
    pub f: &'a [c64],
    pub weights: Weights<'a>,
    pub m: usize,
    pub p: usize,
}

impl OeData<'_> {
    pub fn s(&self) -> usize {
        self.omega.len()
    }

    pub(crate) fn validate(&self) -> Result<(), PodidError> {
        let (s, p, m) = (self.s(), self.p, self.m);
        let bad = |msg: String| Err(PodidError::Invalid(msg));
        if s == 0 || p == 0 || m == 0 {
            return bad(format!("empty data: s = {s} lines, p = {p}, m = {m}"));
        }
        if self.u.len() != s * p * m || self.f.len() != s * p * m {
            return bad(format!(
                "u and f must hold s·p·m = {} values, got {} and {}",
                s * p * m,
                self.u.len(),
                self.f.len()
            ));
        }
        let finite = |z: &c64| z.re.is_finite() && z.im.is_finite();
        if !self.u.iter().all(finite) || !self.f.iter().all(finite) {
            return bad("u or f contains NaN or inf".into());
        }
        if !self.omega.iter().all(|w| w.is_finite() && *w > 0.0) {
            return bad("omega must be finite and strictly positive".into());
        }
        match self.weights {
            Weights::Scalar(w) => {
                if w.len() != s * p {
                    return bad(format!("scalar weights: expected s·p = {} values", s * p));
                }
                if !w.iter().all(|v| v.is_finite() && *v >= 0.0) {
                    return bad("weights must be finite and non-negative".into());
                }
                if w.iter().all(|v| *v == 0.0) {
                    return bad("every weight is zero: there is nothing to fit".into());
                }
            }
            Weights::Matrix(t) => {
                if t.len() != s * p * m * m {
                    return bad(format!(
                        "matrix weights: expected s·p·m² = {} values",
                        s * p * m * m
                    ));
                }
                if !t.iter().all(|v| v.is_finite()) {
                    return bad("weights must be finite".into());
                }
            }
            Weights::LogMagnitude(lt) => {
                let n = lt.n;
                if n == 0 || lt.basis.len() != n * m {
                    return bad(format!(
                        "log-magnitude basis: expected n·m = {} values (n = {n})",
                        n * m
                    ));
                }
                if !lt.basis.iter().all(|v| v.is_finite()) {
                    return bad("log-magnitude basis contains NaN or inf".into());
                }
                if lt.u.len() != s * p * n || lt.w.len() != s * p * n {
                    return bad(format!(
                        "log-magnitude targets and weights: expected s·p·n = {} values each",
                        s * p * n
                    ));
                }
                if !lt.w.iter().all(|v| v.is_finite() && *v >= 0.0) {
                    return bad("weights must be finite and non-negative".into());
                }
                if lt.w.iter().all(|v| *v == 0.0) {
                    return bad("every weight is zero: there is nothing to fit".into());
                }
                if !lt.u.iter().all(finite) {
                    return bad("log-magnitude targets contain NaN or inf".into());
                }
                if lt
                    .u
                    .iter()
                    .zip(lt.w)
                    // |z| by hypot, as NumPy's abs: |z|² underflows to 0 below 1.5e-162
                    .any(|(z, w)| *w > 0.0 && z.norm() == 0.0)
                {
                    return bad(
                        "a weighted target entry is zero: its log-magnitude is undefined \
                         (give it weight 0)"
                            .into(),
                    );
                }
            }
        }
        Ok(())
    }
}
