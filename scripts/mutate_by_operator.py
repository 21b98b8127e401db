"""Reviewer's operators applied at every place they fit, over the pipeline's modules.

``mutate_by_hand.py`` holds bugs a person chose; mutmut's operators are generic (``<`` for
``<=``, a string changed, an argument dropped), and only a sample of its mutants is run.
The kinds of bug below kept surviving the hand-made audits, because the test fixtures hid
them; most of them mutmut never makes. This script makes them everywhere, so that none is
left to a reviewer's luck:

- **one side of a two-sided check**: every ``!=`` becomes ``<`` and, separately, ``>``
  (a shape check tested only with too few lines passes a check that refuses only too few);
- **a transpose or a conjugate dropped**: every ``.T`` and every ``.conj()`` removed
  (symmetric matrices and real forces in the fixtures hide them);
- **a reversal dropped**: every ``[::-1]`` removed;
- **the wrong axis**: every ``axis=0`` becomes ``axis=1`` and the reverse;
- **an option ignored**: a parameter with a default read as that default, at one of its
  uses at a time (numbered after the operators above; an option tested at one value only,
  or not passed on, lets it through);
- **a count's boundary**: ``<`` and ``<=``, ``>`` and ``>=`` exchanged where a count or a
  size is compared (an integer literal on either side, or ``len``, ``.size``, ``.shape``,
  ``.ndim`` on the line): a limit tested on one side only lets it through (numbered after
  the options);
- **the wrong one of two similar names**: a name read where a similar one of the same
  function was meant (``M``, ``C`` and ``K`` for each other; ``db_before`` for ``db_after``,
  ``U_m`` for ``F_m``, ``omega`` for ``omega_fit``: names sharing their first or their last
  words), and an attribute of one object for a similar one of the same object
  (``model.M`` for ``model.K``, ``fit.train_db`` for ``fit.test_db``), at one use at a
  time; only names already bound at the line are used (numbered after the boundaries);
- **a matrix read transposed**: every read of ``M``, ``C`` or ``K`` (a name, or an
  attribute such as ``model.K``) read as its transpose, at one use at a time (every
  fixture's model symmetric lets it through where a user's unsymmetric one would not;
  numbered last).

Each mutant runs the module's test files of ``mutate_by_hand.py`` (``TESTS`` and
``AUDIT_TESTS``). Run from anywhere:

    python3 scripts/mutate_by_operator.py --list            # every mutant, numbered
    python3 scripts/mutate_by_operator.py                   # run them all
    python3 scripts/mutate_by_operator.py pod modes         # only these modules' mutants
    python3 scripts/mutate_by_operator.py 3 12 40-55        # only these numbers

Mutants are numbered in the order of the modules below and of their places in the file;
a number is stable while the modules' sources are. Every survivor gets the test that
kills it, or goes into ``EQUIVALENT`` below with the reason no input can tell it apart
(those are reported, not run). Do not edit the package, or list the mutants of the same
checkout, while it runs: both read the sources it is mutating.
"""

from __future__ import annotations

import ast
import io
import re
import sys
import tokenize
import warnings
from collections.abc import Iterator

from mutate_by_hand import AUDIT_TESTS, PKG, TESTS, run_mutant

#: the pipeline's modules, as the mutation runs name them
MODULES = [
    "pod", "simulation", "measured", "physical", "modes", "stabilisation", "statespace",
    "io/uff", "io/npz", "identification/refinement", "identification/order",
    "identification/latent", "identification/lines", "identification/holes",
    "identification/modal_start",
]

def _each_read_transposed(mod: str, line: str, reads: str,
                          reason: str) -> dict[tuple[str, str, str], str]:
    """``EQUIVALENT`` entries for every read of ``M``, ``C`` or ``K`` in the part ``reads``
    of ``line`` (once in it) read transposed, one at a time, all for one ``reason``."""
    assert line.count(reads) == 1, (line, reads)
    at = line.index(reads)
    names = [m.end() for m in re.finditer(r"\b[MCK]\b(?![.=\"])", reads)]
    return {(mod, line, line[:at] + reads[:e] + ".T" + reads[e:] + line[at + len(reads):]):
            reason for e in names}


#: reasons that several survivors share (EQUIVALENT below)
_M_AND_K_SORT_AFTER_C = (
    'name runs over the literal ("M", "C", "K") and both "M" and "K" sort after "C", '
    'so > "C" is true exactly where != "C" is'
)
_DEN_ZERO_ONLY_WHERE_NUM_IS = (
    "den = Σ w²|g|² is a sum of non-negative terms, so for finite data it is 0 only where "
    "each term is (w = 0 or g = 0), and there each term w²·Re(ḡ·r) of num is 0 too: num <= 0 "
    "skips the candidate as den <= 0 would (short of every w·|g| lying below 1e-162, whose "
    "square underflows to 0: a candidate's weighted response 1e-162 of the data's)."
)
_M_MODEL_IS_M_PAST_THE_SHAPE_CHECK = (
    "past the start's shape check (M0.shape == (m, m), or refine raises), m_model = "
    "M0.shape[0] is m."
)
_A_SYSTEM_START_IS_READ_SYMMETRISED = (
    "a SecondOrderSystem's M, C, K are square of one shape (its constructor refuses others), "
    "so refine's shape checks see the same shapes, and refine reads their values only in "
    "physical_start, whose 0.5 * (X + X.T) is the same bits for X transposed (IEEE addition "
    "commutes) and whose relative change ‖Y − X‖/‖X‖ (Y symmetric bit for bit) then sums the "
    "same entries in another order: round-off only (up to 3 ulp in 624 of 4000 random matrices "
    "measured, equal in the rest), which no tolerance a test could defend separates."
)
_A_TUPLE_START_IS_READ_SYMMETRISED = (
    "the tuple's matrices are refused unless square on the lines above, so refine's shape "
    "checks see the same shapes, and refine reads their values only in physical_start, whose "
    "0.5 * (X + X.T) is the same bits for X transposed (IEEE addition commutes) and whose "
    "relative change ‖Y − X‖/‖X‖ (Y symmetric bit for bit) then sums the same entries in "
    "another order: round-off only (up to 3 ulp in 624 of 4000 random matrices measured), "
    "which no tolerance a test could defend separates."
)
_PHYSICAL_START_READS_THE_SYMMETRIC_PART = (
    "physical_start's one caller, refine, passes it matrices checked square (m, m); there 0.5 "
    "* (X + X.T) is the same bits for X transposed (IEEE addition commutes), so d, Q and the "
    "returned matrices are, and the relative change ‖Y − X‖/‖X‖ (Y symmetric bit for bit) sums "
    "the same entries in another order: round-off only (up to 3 ulp in 624 of 4000 random "
    "matrices measured), which no tolerance a test could defend separates."
)
_THE_CORE_OUTPUT_IS_SYMMETRISED_NEXT = (
    "the core's out.M, out.C, out.K are read only here, and the next line makes each X 0.5 * "
    "(X + X.T): for X transposed that is 0.5 * (X.T + X), the same bits (IEEE addition "
    "commutes)."
)
_THE_SYMMETRISATION_COMMUTES = (
    "0.5 * (X.T + X.T.T) is 0.5 * (X.T + X), the same bits as 0.5 * (X + X.T) (IEEE addition "
    "commutes)."
)
_SYMMETRISED_A_FEW_LINES_ABOVE = (
    "M, C, K were made 0.5 * (X + X.T) a few lines above, whose (i, j) and (j, i) entries are "
    "the same two numbers added in either order, equal bit for bit (IEEE addition commutes): "
    "the transpose is the same matrix."
)
_THE_SWEEPS_FITS_ARE_SYMMETRIC = (
    "best.model is a fit of the sweep (sweep_orders, the only caller), which makes its models "
    "only by refine, whose M, C, K are symmetric bit for bit (0.5 * (X + X.T)), and the tuple "
    "is read only by _extend, which copies its values into fresh arrays: the same starts bit "
    "for bit (two sweeps of the 8-DOF chain, one with latent orders, gave the same fits bit "
    "for bit with all three transposed here and where previous is set)."
)
_REFINED_MODELS_ARE_SYMMETRIC = (
    "model is refine's result here (a trial's, _refine_quietly's or _converged's), whose M, C, "
    "K are symmetric bit for bit (0.5 * (X + X.T)), so the transposes are the same values in a "
    "Fortran-ordered view, read by copies (_extend, _with_mode), eigvalsh of the symmetric "
    "part and SecondOrderSystem.response (the same bits, measured): two sweeps of the 8-DOF "
    "chain, one with latent orders, gave the same fits bit for bit."
)

#: survivors no input can tell apart from the code, each with the reason: (module, the line
#: as written, the mutated line), both stripped of indentation
EQUIVALENT: dict[tuple[str, str, str], str] = {
    # pod, simulation
    ("pod", "return 0.5 * (R + R.T)", "return 0.5 * (R + R)"):
        "R is u.T @ u / r or A.T @ A of a fresh contiguous float64 array (as_array's copy, "
        "_stacked_rows' reshape), which numpy's matmul forms by syrk and a copied triangle: "
        "R.T equals R bit for bit.",
    ("pod", "if ka.ndim != 0 or not 0 < ka <= 1:", "if ka.ndim > 0 or not 0 < ka <= 1:"):
        "an array's ndim is never negative, so ndim > 0 is ndim != 0.",
    ("pod", "mu, V = np.linalg.eigh(0.5 * (G + G.T))", "mu, V = np.linalg.eigh(0.5 * (G + G))"):
        "G = A @ A.T of a fresh contiguous float64 array (as_array's copy or _stacked_rows' "
        "reshape), formed by numpy's matmul with syrk and a copied triangle: G.T equals G bit "
        "for bit.",
    ("pod", "P = pod_from_correlation(0.5 * (R + R.T))", "P = pod_from_correlation(0.5 * (R + R))"):
        "R = scale * (A.T @ A) of _stacked_rows' contiguous array: syrk with a copied triangle, "
        "times a scalar, so R.T equals R bit for bit.",
    ("pod", "theta, W = np.linalg.eigh(0.5 * (T + T.T))",
     "theta, W = np.linalg.eigh(0.5 * (T + T))"):
        "T = diag(lam) - Q^T D Q is symmetric in exact arithmetic for every input; its computed "
        "asymmetry is round-off (up to 5e-17 of max|T| measured), so eigh of one triangle "
        "differs from eigh of the symmetric part by eigh's own round-off (up to 6e-16 of "
        "max|T|), which no tolerance a test could defend separates.",
    ("simulation", "if snr.ndim != 0:", "if snr.ndim > 0:"):
        "an array's ndim is never negative, so ndim > 0 is ndim != 0.",
    ("simulation", "if welch.x.shape[2] != 1:", "if welch.x.shape[2] > 1:"):
        "_records refuses forces without a channel (shape[2] == 0), so shape[2] >= 1 here and "
        "> 1 is != 1.",
    # io/uff, io/npz
    ("io/uff", "while (at := raw.find(_DELIMITER, at + 1)) != -1:",
     "while (at := raw.find(_DELIMITER, at + 1)) > -1:"):
        "bytes.find returns -1 or an offset >= 0, so != -1 and > -1 are the same test.",
    ("io/uff", "if x.ndim != 1 or y.shape != x.shape or x.size < 2:",
     "if x.ndim > 1 or y.shape != x.shape or x.size < 2:"):
        "the only ndim under 1 is a 0-d abscissa, of size 1, which x.size < 2 refuses on the "
        "same line with the same message.",
    ("io/uff", "elif by_reciprocity or columns != refs:",
     "elif by_reciprocity or columns < refs:"):
        "evaluated only when by_reciprocity == 0, where every reference is a column (else it "
        "would count) and every column a reference (_force_columns drops a column that is "
        "only a response: the references cover all its pairs), so columns == refs and !=, < "
        "and > are all False.",
    ("io/uff", "elif by_reciprocity or columns != refs:",
     "elif by_reciprocity or columns > refs:"):
        "as with <: evaluated only when by_reciprocity == 0, where columns == refs.",
    ("io/uff",
     "if np.any(g[:, 0] != np.round(g[:, 0])) or np.unique(g[:, 0]).size != g.shape[0]:",
     "if np.any(g[:, 0] != np.round(g[:, 0])) or np.unique(g[:, 0]).size < g.shape[0]:"):
        "np.unique of the g.shape[0] node numbers holds at most g.shape[0] of them, so != and "
        "< are the same test.",
    ("io/uff",
     "if np.unique(idx).size != idx.size:  # as MeasuredData: one load case per driven DOF",
     "if np.unique(idx).size < idx.size:  # as MeasuredData: one load case per driven DOF"):
        "np.unique of the flat idx holds at most idx.size values, so != and < are the same "
        "test.",
    # identification/latent, lines, holes, modal_start
    ("identification/holes", "lam, V = np.linalg.eigh(0.5 * (Q + Q.T))",
     "lam, V = np.linalg.eigh(0.5 * (Q + Q))"):
        "Q = Rᵀ diag(d) R with d of 0 and 1 has in its two triangles the same products "
        "R_ni·R_nj, summed in orders the BLAS chooses, so the triangles differ by rounding "
        "only (not always bit for bit) and eigh, which reads one, gets an input moved "
        "within its own backward error: for any R and mask nothing beyond round-off changes.",
    ("identification/modal_start", "return (M + M.T) / 2, (C + C.T) / 2, (K + K.T) / 2",
     "return (M + M) / 2, (C + C.T) / 2, (K + K.T) / 2"):
        "M = A_inv.T @ A_inv is one array times its own transpose, which NumPy's matmul "
        "computes with BLAS syrk and mirrors, so M is symmetric bit for bit and "
        "(M + M) / 2 and (M + M.T) / 2 are both exactly M.",
    # measured, physical, modes, stabilisation, statespace
    ("measured", "if np.unique(idx).size != idx.size:", "if np.unique(idx).size < idx.size:"):
        "np.unique never returns more elements than it is given, so its size is <= idx.size "
        "and != is <",
    # identification/refinement, identification/order
    ("identification/refinement", 'if name != "C" and not np.any(d > 0):',
     'if name > "C" and not np.any(d > 0):'):
        _M_AND_K_SORT_AFTER_C,
    ("identification/refinement",
     'keep = d.min() >= (START_KEEP * np.abs(d).max() if name != "C" else 0.0)',
     'keep = d.min() >= (START_KEEP * np.abs(d).max() if name > "C" else 0.0)'):
        _M_AND_K_SORT_AFTER_C,
    # identification/refinement: an option ignored
    ("identification/refinement",
     'if mask is not None and objective == "complex" and not label.endswith("per entry"):',
     'if mask is not None and "complex" == "complex" and not label.endswith("per entry"):'):
        'objective is validated to "complex" or "log-magnitude", and every label '
        '_log_magnitude_targets returns ends with "per entry", so for the log-magnitude '
        "objective the last test is False either way.",
    # pod, simulation, measured, physical, modes, stabilisation, io/uff: a count's boundary
    ("io/uff", "if k > 0:", "if k >= 0:"):
        "the loop runs only with two delimiters or more, in increasing order, so at k = 0 "
        "the gap raw[tags[-1] + 6:tags[0]] starts after it ends: empty, never refused.",
    ("io/uff",
     'whole = len(body) >= expected * size and not body[expected * size:].strip(b"\\r\\n")',
     'whole = len(body) > expected * size and not body[expected * size:].strip(b"\\r\\n")'):
        "at len(body) == expected * size the mutant's whole is False and held is "
        "len(body) // size, which is expected, as the original's: the same count.",
    ("io/uff", "if len(counts) > 1:", "if len(counts) >= 1:"):
        "with one label the mutant ranks it alone (no tie), takes it as the unit and keeps "
        "every record (each agrees with itself or has none): what skipping the block does.",
    # identification/refinement, order, latent, lines, modal_start: a count's boundary
    ("identification/order", "if den <= 0 or num <= 0:", "if den < 0 or num <= 0:"):
        _DEN_ZERO_ONLY_WHERE_NUM_IS,
    ("identification/latent", "if den <= 0 or num <= 0:", "if den < 0 or num <= 0:"):
        _DEN_ZERO_ONLY_WHERE_NUM_IS,
    ("identification/order", "flat = (flat + 1 if order > observed and len(fits) > 1",
     "flat = (flat + 1 if order > observed and len(fits) >= 1"):
        "each pass of the sweep appends its fit or leaves the loop, so here len(fits) is the "
        "order, and order 1 > observed means observed = 0, where the pass fails before its "
        "fit (basis(0) is refused): wherever order > observed is reached here len(fits) >= 2, "
        "and > 1 and >= 1 agree.",
    ("identification/modal_start", "zeta = -lam.real / np.where(wn > 0, wn, 1.0)",
     "zeta = -lam.real / np.where(wn >= 0, wn, 1.0)"):
        "lam was filtered to lam.imag > 0 two lines above, so every wn = |lam| >= lam.imag "
        "> 0 (a NaN fails both tests): np.where picks wn either way.",
    ("identification/modal_start", "rank = int(np.sum(sv > 1e-3 * sv[0])) if sv[0] > 0 else 0",
     "rank = int(np.sum(sv > 1e-3 * sv[0])) if sv[0] >= 0 else 0"):
        "the singular values are non-negative and sv[0] is the largest, so sv[0] == 0 makes "
        "every one 0 and np.sum(sv > 0) is 0, the value of the else branch (a NaN fails "
        "both tests).",
    # identification/order, latent, lines, modal_start: an option ignored
    ("identification/lines",
     "if isinstance(target, bool) or not isinstance(target, int | np.integer) or target < 16:",
     "if isinstance(SWEEP_LINES, bool) or not isinstance(target, int | np.integer) or target "
     "< 16:"):
        "a bool target is True or False (bool cannot be subclassed), an int below 16: the "
        "line's last test refuses it with the same message, so the first test adds nothing.",
    # pod, simulation, measured, physical: the wrong one of two similar names
    ("measured", "return np.arange(n)", "return np.arange(n_in)"):
        "the one caller passes n and n_in as U.shape[1] and F.shape[1] (ints), and two lines "
        "above n_in != n raises, so here n_in is n.",
    # modes, stabilisation, statespace, io/npz, refinement, latent, modal_start: similar names
    ("identification/refinement", "if X.shape != (m, m):", "if X.shape != (m, m_model):"):
        "M0 is checked first and m_model is M0.shape[0], so the mutant passes M0 only when "
        "M0.shape == (m, M0.shape[0]), i.e. M0 is (m, m), as the original; C0 and K0 are "
        "then checked with m_model == m, against (m, m) as the original.",
    ("identification/refinement", "weighting = _scalar_weights(w, m, observed)",
     "weighting = _scalar_weights(w, m_model, observed)"):
        _M_MODEL_IS_M_PAST_THE_SHAPE_CHECK,
    ("identification/refinement", "X = rows.reshape(data.s, p, m).transpose(0, 2, 1)",
     "X = rows.reshape(data.s, p, m_model).transpose(0, 2, 1)"):
        _M_MODEL_IS_M_PAST_THE_SHAPE_CHECK,
    ("identification/refinement", '"gauge": gauge_dimension(m, observed)},',
     '"gauge": gauge_dimension(m_model, observed)},'):
        _M_MODEL_IS_M_PAST_THE_SHAPE_CHECK,
    ("identification/refinement", "n_unk = 3 * m * (m + 1) // 2",
     "n_unk = 3 * m_model * (m + 1) // 2"):
        _M_MODEL_IS_M_PAST_THE_SHAPE_CHECK,
    ("identification/refinement", "n_unk = 3 * m * (m + 1) // 2",
     "n_unk = 3 * m * (m_model + 1) // 2"):
        _M_MODEL_IS_M_PAST_THE_SHAPE_CHECK,
    ("identification/refinement", "rank=n_unk - gauge_dimension(m, observed),",
     "rank=n_unk - gauge_dimension(m_model, observed),"):
        _M_MODEL_IS_M_PAST_THE_SHAPE_CHECK,
    ("identification/modal_start", "m = M.shape[0]", "m = C.shape[0]"):
        "m only sizes the state matrix's zeros and identity, and its second block row "
        "np.linalg.solve(M, C) refuses a C whose rows are not M's: wherever the state "
        "matrix is built C.shape[0] is M.shape[0] (the one caller, the order sweep, passes "
        "refine's models, M, C, K square of one shape).",
    ("identification/modal_start", "m = M.shape[0]", "m = K.shape[0]"):
        "m only sizes the state matrix's zeros and identity, and its second block row "
        "np.linalg.solve(M, K) refuses a K whose rows are not M's: wherever the state "
        "matrix is built K.shape[0] is M.shape[0] (the one caller, the order sweep, passes "
        "refine's models, M, C, K square of one shape).",
    ("identification/modal_start",
     "done = np.linalg.norm(a_next - a) <= 1e-15 * np.linalg.norm(a_next)",
     "done = np.linalg.norm(a_next - a) <= 1e-15 * np.linalg.norm(a)"):
        "| ‖a_next‖ − ‖a‖ | ≤ ‖a_next − a‖, so the two thresholds differ by at most 1e-15 of "
        "the step: the tests disagree only for a step within round-off of its threshold, "
        "and then one step of 1e-15 of the shape more or less is taken: the shape moves "
        "by round-off.",
    # identification/order: the wrong one of two similar names
    ("identification/order",
     "mask = np.ones(U_n.shape[1:], dtype=bool) if measured is None else measured",
     "mask = np.ones(F_n.shape[1:], dtype=bool) if measured is None else measured"):
        "_relative_cost runs only in final_fit, whose first line (_check_forces) refuses F_n "
        "of another shape than U_n and which passes both indexed by the same lines: "
        "F_n.shape[1:] is U_n.shape[1:] there.",
    ("identification/order", "s, n, p = U_n.shape", "s, n, p = F_n.shape"):
        "_check_forces on the line above refuses F_n of another shape than U_n, so F_n.shape "
        "is U_n.shape here.",
    ("identification/order", "if chosen == m", "if chosen == m_max"):
        "in sweep_orders' branch for a given m, m_max was set to m (m_max = m) and neither "
        "name is bound again: m_max == m.",
    ("identification/order",
     'else f"m = {chosen}: order {chosen + 1} could not be started (m = {m} was asked; "',
     'else f"m = {chosen}: order {chosen + 1} could not be started (m = {m_max} was asked; "'):
        "in sweep_orders' branch for a given m, m_max was set to m (m_max = m) and neither "
        "name is bound again: m_max == m, the same number in the reason.",
    ("identification/order", "measured = check_measured(measured, *U_n.shape[1:])",
     "measured = check_measured(measured, *F_n.shape[1:])"):
        "final_fit's first line (_check_forces) refuses F_n of another shape than U_n, so "
        "F_n.shape[1:] is U_n.shape[1:] here.",
    # physical, modes, stabilisation, statespace: a matrix read transposed
    ("physical", "after = residual_norm(M, C, K, data)",
     "after = residual_norm(M.T, C, K, data)"):
        "make_physical's M, C and K here are nearest_psd's 0.5 * (B + Bᵀ), exactly symmetric (IEEE"
        " addition commutes, so entries (i, j) and (j, i) are the same sum): the transpose has the"
        " same values.",
    ("physical", "after = residual_norm(M, C, K, data)",
     "after = residual_norm(M, C.T, K, data)"):
        "as for the mutant of the same line above: the same reason.",
    ("physical", "after = residual_norm(M, C, K, data)",
     "after = residual_norm(M, C, K.T, data)"):
        "as for the mutant of the same line above: the same reason.",
    ("physical", "for new, old in ((M, result.M), (C, result.C), (K, result.K))",
     "for new, old in ((M.T, result.M), (C, result.C), (K, result.K))"):
        "new is nearest_psd's 0.5 * (B + Bᵀ), exactly symmetric (IEEE addition commutes), so new.T"
        " has new's values and the relative change is the same.",
    ("physical", "for new, old in ((M, result.M), (C, result.C), (K, result.K))",
     "for new, old in ((M, result.M.T), (C, result.C), (K, result.K))"):
        "new is exactly symmetric (nearest_psd's 0.5 * (B + Bᵀ)), so new − oldᵀ is (new − old)ᵀ "
        "entry for entry and ‖oldᵀ‖ has old's entries: the Frobenius norms are equal, up to the "
        "order numpy sums the same squares in.",
    ("physical", "for new, old in ((M, result.M), (C, result.C), (K, result.K))",
     "for new, old in ((M, result.M), (C.T, result.C), (K, result.K))"):
        "as for M.T read as new above: the same reason.",
    ("physical", "for new, old in ((M, result.M), (C, result.C), (K, result.K))",
     "for new, old in ((M, result.M), (C, result.C.T), (K, result.K))"):
        "as for result.M.T read as old above: the same reason.",
    ("physical", "for new, old in ((M, result.M), (C, result.C), (K, result.K))",
     "for new, old in ((M, result.M), (C, result.C), (K.T, result.K))"):
        "as for M.T read as new above: the same reason.",
    ("physical", "for new, old in ((M, result.M), (C, result.C), (K, result.K))",
     "for new, old in ((M, result.M), (C, result.C), (K, result.K.T))"):
        "as for result.M.T read as old above: the same reason.",
    ("physical", "M=M,",
     "M=M.T,"):
        "the corrected matrix is nearest_psd's 0.5 * (B + Bᵀ), exactly symmetric (IEEE addition "
        "commutes): its transpose has the same values, even read from its buffer in either order.",
    ("physical", "C=C,",
     "C=C.T,"):
        "as for M=M.T above: the same reason.",
    ("physical", "K=K,",
     "K=K.T,"):
        "as for M=M.T above: the same reason.",
    ("physical", "n = M.shape[0] if M.ndim == 2 else -1  # (-1, -1): no array's shape",
     "n = M.T.shape[0] if M.ndim == 2 else -1  # (-1, -1): no array's shape"):
        "for a square M, M.T.shape[0] is M.shape[0]; for a 2-D M that is not square M's own shape "
        "fails X.shape != (n, n) with either n and the message prints the matrices' shapes, not n.",
    ("physical", "n = M.shape[0] if M.ndim == 2 else -1  # (-1, -1): no array's shape",
     "n = M.shape[0] if M.T.ndim == 2 else -1  # (-1, -1): no array's shape"):
        "a transpose has its array's ndim.",
    ("physical", "if any(X.shape != (n, n) for X in (M, C, K)):",
     "if any(X.shape != (n, n) for X in (M.T, C, K)):"):
        "X.T.shape is X.shape reversed, and a shape equals (n, n) exactly when its reversal does.",
    ("physical", "if any(X.shape != (n, n) for X in (M, C, K)):",
     "if any(X.shape != (n, n) for X in (M, C.T, K)):"):
        "as for the mutant of the same line above: the same reason.",
    ("physical", "if any(X.shape != (n, n) for X in (M, C, K)):",
     "if any(X.shape != (n, n) for X in (M, C, K.T)):"):
        "as for the mutant of the same line above: the same reason.",
    ("modes",
     "return all(np.linalg.norm(X - X.T) <= SYMMETRY_RTOL * np.linalg.norm(X)"
     " for X in (M, C, K))",
     "return all(np.linalg.norm(X - X.T) <= SYMMETRY_RTOL * np.linalg.norm(X)"
     " for X in (M.T, C, K))"):
        "‖Xᵀ − X‖ is of the entries of X − Xᵀ negated (a − b is −(b − a) exactly) and ‖Xᵀ‖ of X's "
        "entries: the symmetry test gets the same norms, up to the order numpy sums the same "
        "squares in.",
    ("modes",
     "return all(np.linalg.norm(X - X.T) <= SYMMETRY_RTOL * np.linalg.norm(X)"
     " for X in (M, C, K))",
     "return all(np.linalg.norm(X - X.T) <= SYMMETRY_RTOL * np.linalg.norm(X)"
     " for X in (M, C.T, K))"):
        "as for the mutant of the same line above: the same reason.",
    ("modes",
     "return all(np.linalg.norm(X - X.T) <= SYMMETRY_RTOL * np.linalg.norm(X)"
     " for X in (M, C, K))",
     "return all(np.linalg.norm(X - X.T) <= SYMMETRY_RTOL * np.linalg.norm(X)"
     " for X in (M, C, K.T))"):
        "as for the mutant of the same line above: the same reason.",
    ("modes", "M, C = model.M, model.C",
     "M, C = model.M.T, model.C"):
        "M and C are used only in the symmetry test (transpose-invariant: the same entries) and in"
        " modal A's quadratic forms ψᵀXψ (einsum ik,ij,jk, no conjugate), and ψᵀXᵀψ = (ψᵀXψ)ᵀ is "
        "the same scalar for every X: the same sums in another order.",
    ("modes", "M, C = model.M, model.C",
     "M, C = model.M, model.C.T"):
        "as for the mutant of the same line above: the same reason.",
    ("modes", "if _is_symmetric(M, C, model.K):",
     "if _is_symmetric(M.T, C, model.K):"):
        "as for _is_symmetric's own line above: the same reason.",
    ("modes", "if _is_symmetric(M, C, model.K):",
     "if _is_symmetric(M, C.T, model.K):"):
        "as for the mutant of the same line above: the same reason.",
    ("modes", "if _is_symmetric(M, C, model.K):",
     "if _is_symmetric(M, C, model.K.T):"):
        "as for the mutant of the same line above: the same reason.",
    ("modes", "modal_a = lam * np.einsum(\"ik,ij,jk->k\", psi, 2 * M, psi) + np.einsum(",
     "modal_a = lam * np.einsum(\"ik,ij,jk->k\", psi, 2 * M.T, psi) + np.einsum("):
        "modal A's ψᵀXψ (einsum ik,ij,jk, no conjugate) is a scalar, equal to its own transpose "
        "ψᵀXᵀψ for every X: the same products summed in another order.",
    ("modes", "\"ik,ij,jk->k\", psi, C, psi",
     "\"ik,ij,jk->k\", psi, C.T, psi"):
        "as for 2 * M.T in modal A above: the same reason.",
    ("stabilisation", "mats = (model.M, model.C, model.K)",
     "mats = (model.M.T, model.C, model.K)"):
        "is_physical reads each matrix only through ‖X − Xᵀ‖ against ‖X‖ (for Xᵀ the same entries,"
        " negated) and eigvalsh of 0.5 (X + Xᵀ), which for Xᵀ is the same array bit for bit (IEEE "
        "addition commutes).",
    ("stabilisation", "mats = (model.M, model.C, model.K)",
     "mats = (model.M, model.C.T, model.K)"):
        "as for the mutant of the same line above: the same reason.",
    ("stabilisation", "mats = (model.M, model.C, model.K)",
     "mats = (model.M, model.C, model.K.T)"):
        "as for the mutant of the same line above: the same reason.",
    # identification/refinement, order, modal_start: a model's matrix read transposed
    **_each_read_transposed(
        'identification/refinement', 'return model.M, model.C, model.K, None',
        'model.M, model.C, model.K', _A_SYSTEM_START_IS_READ_SYMMETRISED),
    **_each_read_transposed(
        'identification/refinement', 'return M, C, K, None',
        'M, C, K', _A_TUPLE_START_IS_READ_SYMMETRISED),
    **_each_read_transposed(
        'identification/refinement',
        'for X, name, tol in ((M, "M", rtol), (C, "C", 0.0), (K, "K", rtol)):',
        '((M, "M", rtol), (C, "C", 0.0), (K, "K", rtol))',
        _PHYSICAL_START_READS_THE_SYMMETRIC_PART),
    **_each_read_transposed(
        'identification/refinement',
        'M, C, K = (np.asarray(X, dtype=np.float64) for X in (out.M, out.C, out.K))',
        '(out.M, out.C, out.K)', _THE_CORE_OUTPUT_IS_SYMMETRISED_NEXT),
    **_each_read_transposed(
        'identification/refinement', 'M, C, K = (0.5 * (X + X.T) for X in (M, C, K))',
        '(M, C, K))', _THE_SYMMETRISATION_COMMUTES),
    ("identification/refinement", "M=M,", "M=M.T,"):
        _SYMMETRISED_A_FEW_LINES_ABOVE,
    ("identification/refinement", "C=C,", "C=C.T,"):
        _SYMMETRISED_A_FEW_LINES_ABOVE,
    ("identification/refinement", "K=K,", "K=K.T,"):
        _SYMMETRISED_A_FEW_LINES_ABOVE,
    **_each_read_transposed(
        'identification/refinement',
        'residual_norm=residual_norm(M, C, K, data) if latent == 0 else math.nan,',
        '(M, C, K, data)', _SYMMETRISED_A_FEW_LINES_ABOVE),
    **_each_read_transposed(
        'identification/order', 'model = (best.model.M, best.model.C, best.model.K)',
        '(best.model.M, best.model.C, best.model.K)', _THE_SWEEPS_FITS_ARE_SYMMETRIC),
    **_each_read_transposed(
        'identification/order', 'previous = (model.M, model.C, model.K)',
        '(model.M, model.C, model.K)', _REFINED_MODELS_ARE_SYMMETRIC),
    ("identification/modal_start",
     "if not (M.ndim == 2 and M.shape[0] == M.shape[1] and M.shape == C.shape == K.shape):",
     "if not (M.T.ndim == 2 and M.shape[0] == M.shape[1] and M.shape == C.shape == K.shape):"):
        "a transpose has its array's ndim.",
    ("identification/modal_start",
     "if not (M.ndim == 2 and M.shape[0] == M.shape[1] and M.shape == C.shape == K.shape):",
     "if not (M.ndim == 2 and M.shape[0] == M.shape[1] and M.T.shape == C.shape == K.shape):"):
        "the two conditions before it (and short-circuits) have made M a square 2-D matrix, whose "
        "transpose has its shape.",
    ("identification/modal_start",
     "if not (M.ndim == 2 and M.shape[0] == M.shape[1] and M.shape == C.shape == K.shape):",
     "if not (M.ndim == 2 and M.shape[0] == M.shape[1] and M.shape == C.T.shape == K.shape):"):
        "M is square (n, n) where this is reached, so M.shape == C.T.shape holds exactly when C is "
        "(n, n), and then C.T.shape == K.shape is C.shape == K.shape.",
    ("identification/modal_start",
     "if not (M.ndim == 2 and M.shape[0] == M.shape[1] and M.shape == C.shape == K.shape):",
     "if not (M.ndim == 2 and M.shape[0] == M.shape[1] and M.shape == C.shape == K.T.shape):"):
        "M and C are square (n, n) where K is compared, so C.shape == K.T.shape holds exactly when "
        "K is (n, n), as C.shape == K.shape does.",
    ("identification/modal_start", "m = M.shape[0]", "m = M.T.shape[0]"):
        "the check above refuses M unless a square 2-D matrix, so M.T.shape[0] is M.shape[0].",
    ("identification/modal_start",
     "return (M + M.T) / 2, (C + C.T) / 2, (K + K.T) / 2",
     "return (M.T + M.T) / 2, (C + C.T) / 2, (K + K.T) / 2"):
        "M = A_inv.T @ A_inv is one array times its own transpose, which NumPy's matmul computes "
        "with BLAS syrk and mirrors (2000 random A: bit-symmetric every time), so M.T is M and "
        "(M.T + M.T) / 2 is (M + M.T) / 2 = M bit for bit.",
}


def _offsets(src: str) -> list[int]:
    """Character offset of the start of each line (1-based line numbers as tokenize's)."""
    starts = [0, 0]
    for line in src.splitlines(keepends=True):
        starts.append(starts[-1] + len(line))
    return starts


def mutants(mod: str) -> Iterator[tuple[int, str, str, str]]:
    """The operator mutants of one module: (line number, line, mutated line, mutated source)."""
    src = (PKG / f"{mod}.py").read_text()
    lines = src.splitlines()
    at = _offsets(src)
    toks = [t for t in tokenize.generate_tokens(io.StringIO(src).readline)
            if t.type not in (tokenize.NL, tokenize.NEWLINE, tokenize.COMMENT)]

    def pos(t: tokenize.TokenInfo, end: bool = False) -> int:
        row, col = t.end if end else t.start
        return at[row] + col

    def cut(a: int, b: int, text: str) -> tuple[int, str, str, str]:
        row = src.count("\n", 0, a) + 1
        new = src[:a] + text + src[b:]
        return row, lines[row - 1], new.splitlines()[row - 1], new

    for k, t in enumerate(toks):
        if t.type == tokenize.OP and t.string == "!=":
            for op in ("<", ">"):
                yield cut(pos(t), pos(t, end=True), op)
        nxt = toks[k + 1] if k + 1 < len(toks) else None
        if t.string == "." and nxt is not None and nxt.type == tokenize.NAME:
            if nxt.string == "T":
                yield cut(pos(t), pos(nxt, end=True), "")
            if (nxt.string == "conj" and k + 3 < len(toks)
                    and toks[k + 2].string == "(" and toks[k + 3].string == ")"):
                yield cut(pos(t), pos(toks[k + 3], end=True), "")
        if t.string == "[" and [u.string for u in toks[k + 1:k + 6]] == [":", ":", "-", "1", "]"]:
            yield cut(pos(t), pos(toks[k + 5], end=True), "")
        if (t.type == tokenize.NAME and t.string == "axis" and nxt is not None
                and nxt.string == "=" and k + 2 < len(toks)
                and toks[k + 2].string in ("0", "1")):
            swap = "1" if toks[k + 2].string == "0" else "0"
            yield cut(pos(toks[k + 2]), pos(toks[k + 2], end=True), swap)


def default_mutants(mod: str) -> Iterator[tuple[int, str, str, str]]:
    """A parameter read as its default at one use: (line number, line, mutated line, source)."""
    src = (PKG / f"{mod}.py").read_text()
    lines = src.splitlines(keepends=True)
    at = _offsets(src)
    found = []
    for f in ast.walk(ast.parse(src)):
        if not isinstance(f, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        a = f.args
        positional = a.posonlyargs + a.args
        with_default = [*zip(positional[len(positional) - len(a.defaults):], a.defaults,
                             strict=True),
                        *((k, d) for k, d in zip(a.kwonlyargs, a.kw_defaults, strict=True)
                          if d is not None)]
        for arg, default in with_default:
            text = ast.get_source_segment(src, default)
            for node in ast.walk(f):
                if (isinstance(node, ast.Name) and node.id == arg.arg
                        and isinstance(node.ctx, ast.Load) and text is not None):
                    # ast's columns count UTF-8 bytes; the source is indexed by character
                    row = lines[node.lineno - 1].encode()
                    a0 = at[node.lineno] + len(row[:node.col_offset].decode())
                    b0 = at[node.lineno] + len(row[:node.end_col_offset].decode())
                    found.append((a0, b0, text))
    for a0, b0, text in sorted(found):
        row = src.count("\n", 0, a0) + 1
        # inside an f-string of the same quotes, a string default needs the other ones
        for written in (text, text.translate(str.maketrans("\"'", "'\""))):
            new = src[:a0] + written + src[b0:]
            try:
                with warnings.catch_warnings():  # e.g. None[...]: the mutant's, not ours
                    warnings.simplefilter("ignore", SyntaxWarning)
                    compile(new, mod, "exec")
            except SyntaxError:
                continue
            yield row, lines[row - 1].rstrip("\n"), new.splitlines()[row - 1], new
            break


#: the boundary operator's exchanges, and what makes a comparison one of counts or sizes
BOUNDARY = {"<": "<=", "<=": "<", ">": ">=", ">=": ">"}
SIZES = ("len(", ".size", ".shape", ".ndim")


def boundary_mutants(mod: str) -> Iterator[tuple[int, str, str, str]]:
    """A count's comparison moved across its boundary: (line number, line, mutated line,
    source)."""
    src = (PKG / f"{mod}.py").read_text()
    lines = src.splitlines()
    at = _offsets(src)
    toks = [t for t in tokenize.generate_tokens(io.StringIO(src).readline)
            if t.type not in (tokenize.NL, tokenize.NEWLINE, tokenize.COMMENT)]

    def integer(t: tokenize.TokenInfo) -> bool:
        return t.type == tokenize.NUMBER and t.string.isdigit()

    for k, t in enumerate(toks):
        if t.type != tokenize.OP or t.string not in BOUNDARY:
            continue
        line = lines[t.start[0] - 1]
        if not (integer(toks[k - 1]) or integer(toks[k + 1])
                or (toks[k + 1].string == "-" and integer(toks[k + 2]))
                or any(size in line for size in SIZES)):
            continue
        a0, b0 = at[t.start[0]] + t.start[1], at[t.end[0]] + t.end[1]
        new = src[:a0] + BOUNDARY[t.string] + src[b0:]
        yield t.start[0], line, new.splitlines()[t.start[0] - 1], new


def similar(a: str, b: str) -> bool:
    """Whether two names are ones a person could write for each other: ``M``, ``C`` and
    ``K``, or names that share their first or their last words (``n_in`` and ``n_out``,
    ``U_m`` and ``F_m``, ``omega`` and ``omega_fit``; case and leading underscores aside)."""
    if a == b:
        return False
    if {a, b} <= {"M", "C", "K"}:
        return True
    wa, wb = a.lstrip("_").lower().split("_"), b.lstrip("_").lower().split("_")
    if len(wa) == len(wb) == 1:
        return False
    if wa[0] == wb[0]:
        return True  # db_before and db_after, n_in and n_out, omega and omega_fit
    return len(wa) > 1 and wa[1:] == wb[1:]  # U_m and F_m


def name_mutants(mod: str) -> Iterator[tuple[int, str, str, str]]:
    """A similar name or attribute read for another at one use: (line number, line, mutated
    line, source)."""
    src = (PKG / f"{mod}.py").read_text()
    lines = src.splitlines(keepends=True)
    at = _offsets(src)
    found = set()
    for f in ast.walk(ast.parse(src)):
        if not isinstance(f, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        a = f.args
        bound = {x.arg: f.lineno for x in [*a.posonlyargs, *a.args, *a.kwonlyargs]}
        attrs: dict[str, set[str]] = {}
        for node in ast.walk(f):
            if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
                bound[node.id] = min(bound.get(node.id, node.lineno), node.lineno)
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
                attrs.setdefault(node.value.id, set()).add(node.attr)
        for node in ast.walk(f):
            if not isinstance(node.__dict__.get("ctx"), ast.Load):
                continue
            row = lines[node.lineno - 1].encode()
            # ast's columns count UTF-8 bytes; the source is indexed by character
            b0 = at[node.lineno] + len(row[:node.end_col_offset].decode())
            if isinstance(node, ast.Name) and node.id in bound:
                others = [o for o, first in bound.items()
                          if first <= node.lineno and similar(node.id, o)]
                found.update((b0 - len(node.id), b0, o) for o in others)
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                    and node.end_lineno == node.lineno):
                others = [o for o in attrs[node.value.id] if similar(node.attr, o)]
                found.update((b0 - len(node.attr), b0, o) for o in others)
    for a0, b0, text in sorted(found):
        row = src.count("\n", 0, a0) + 1
        new = src[:a0] + text + src[b0:]
        yield row, lines[row - 1].rstrip("\n"), new.splitlines()[row - 1], new


def transpose_mutants(mod: str) -> Iterator[tuple[int, str, str, str]]:
    """A model's matrix read as its transpose at one use: (line number, line, mutated line,
    source)."""
    src = (PKG / f"{mod}.py").read_text()
    lines = src.splitlines(keepends=True)
    at = _offsets(src)
    tree = ast.parse(src)
    transposed = {id(n.value) for n in ast.walk(tree)
                  if isinstance(n, ast.Attribute) and n.attr == "T"}
    found = set()
    for node in ast.walk(tree):
        name = (node.id if isinstance(node, ast.Name)
                else node.attr if isinstance(node, ast.Attribute) else None)
        if (name not in ("M", "C", "K") or not isinstance(node.ctx, ast.Load)
                or id(node) in transposed or node.end_lineno != node.lineno):
            continue
        row = lines[node.lineno - 1].encode()
        # ast's columns count UTF-8 bytes; the source is indexed by character
        found.add(at[node.lineno] + len(row[:node.end_col_offset].decode()))
    for b0 in sorted(found):
        row = src.count("\n", 0, b0) + 1
        new = src[:b0] + ".T" + src[b0:]
        yield row, lines[row - 1].rstrip("\n"), new.splitlines()[row - 1], new


def main() -> None:
    """List or run the mutants the command line selects (all without arguments)."""
    args = [a for a in sys.argv[1:] if a != "--list"]
    mods = [a for a in args if a in MODULES] or MODULES
    only: set[int] = set()
    for arg in (a for a in args if a not in MODULES):
        first, _, last = arg.partition("-")
        only.update(range(int(first), int(last or first) + 1))
    i = 0
    counts = {"KILLED": 0, "SURVIVED": 0, "EQUIVALENT": 0}
    for family, mod in [(f, m) for f in (mutants, default_mutants, boundary_mutants, name_mutants,
                                     transpose_mutants)
                        for m in MODULES]:
        for row, line, mutated_line, mutated in family(mod):
            i += 1
            if mod not in mods or (only and i not in only):
                continue
            what = f"{i:3d} {mod}:{row}: {line.strip()!r} -> {mutated_line.strip()!r}"
            if "--list" in sys.argv:
                print(what, flush=True)
                continue
            reason = EQUIVALENT.get((mod, line.strip(), mutated_line.strip()))
            if reason is not None:
                verdict, last = "EQUIVALENT", reason
            else:
                killed, last = run_mutant(mod, mutated, [*TESTS[mod], *AUDIT_TESTS.get(mod, [])])
                verdict = "KILLED" if killed else "SURVIVED"
            counts[verdict] += 1
            print(f"{verdict:10s} {what} | {last}", flush=True)
    if "--list" not in sys.argv:
        print(", ".join(f"{v} {k.lower()}" for k, v in counts.items()))

if __name__ == "__main__":
    main()
