"""NSGA-II-optimised ELM: hidden size, activation and weight scale on the (RMSE, ||beta||_2) front.

Zhang et al. [1] section 3.6: each individual is an ELM's hidden-node
count (1-50), activation (sigmoid, sin, hardlim, tribas, radbas) and
input-weight scale lambda in [0, 1]; NSGA-II [2] minimises two objectives,
the validation RMSE and the 2-norm of the output weights ([1] eq. (25)).
The problem is ours; NSGA-II, its mixed-variable operators and the seeding
are pymoo's ``minimize(..., seed=)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from gyrocomp.models._base import (
    Learner,
    block_split,
    check_choice,
    check_float,
    check_int,
    check_seed,
    check_shape,
    check_X_y,
    finite_array,
    rmse,
)
from gyrocomp.models._nsga2elm_accept import REGIMES, cv_rmse, regime_rmse, regimes, sign_test, significant_everywhere
from gyrocomp.models.elm import ACTIVATIONS, ELM
from gyrocomp.errors import InputError

__all__ = ["NSGA2ELM"]

PICKS = ("knee", "min_rmse")
"""How the one candidate is chosen from the Pareto front."""

ACCEPTS = ("sign_test", "always")
"""When the candidate replaces the plain ELM: better on significantly many cross-validated blocks, or always."""


class NSGA2ELM(Learner):
    """An ELM whose hyper-parameters NSGA-II picks from the (RMSE, ||beta||_2) front.

    Parameters
    ----------
    pop_size : int, default=40
        NSGA-II population ([1] section 4.1).
    crossover : float, default=0.8
        Probability that a pair of parents is recombined ([1] section 4.1):
        SBX on the hidden size (rounded) and on lambda, uniform crossover
        on the activation.
    mutation : float, default=0.15
        Probability that each variable of an offspring is mutated ([1]
        section 4.1): polynomial mutation on hidden size (rounded) and
        lambda, a random other choice for the activation.
    n_gen : int, default=15
        Generations, the initial population counting as the first ([1]
        section 4.1: 15 iterations).
    hidden_range : tuple of int, default=(1, 50)
        Bounds of the hidden-node count ([1] section 3.6 says [0, 50]; an
        ELM needs at least one node).
    activations : tuple of str, default=("sigmoid", "sin", "hardlim", "tribas", "radbas")
        Candidate activations ([1] section 3.6).
    weight_scale_range : tuple of float, default=(0.0, 1.0)
        Bounds of lambda ([1] eq. (24)).
    validation_fraction : float, default=0.2
        Share of the samples (contiguous blocks, seeded) on which the RMSE
        objective is measured; each candidate is trained on the rest.
        [1] does not state its split.
    pick : {"knee", "min_rmse"}, default="knee"
        The candidate taken from the front. ``knee``: among the front
        members whose validation RMSE is at most ``(1 + rmse_tolerance)``
        times the least one, the member closest (Euclidean) to their ideal
        point after scaling both objectives to [0, 1] over those members;
        the least-RMSE member when it is alone there. ``min_rmse``: the
        least validation RMSE. Ties go to the smaller RMSE. See Notes.
    rmse_tolerance : float, default=0.02
        How much validation RMSE (a fraction of the least) the knee may
        give up for a smaller ||beta||_2.
    accept : {"sign_test", "always"}, default="sign_test"
        ``sign_test``: the candidate replaces the plain ELM only when, in a
        blocked ``cv_folds``-fold cross-validation, its error is lower on
        significantly many blocks (one-sided sign test at ``alpha``);
        otherwise the plain ELM is kept (``best_index_`` is None).
        With ``regime_holdout`` it must also pass that check. ``always``:
        the candidate is deployed (the front alone decides, as in [1]). See
        Notes.
    cv_folds : int, default=5
        K of that cross-validation; the samples are cut into ``4 * K``
        contiguous blocks, dealt to the folds in turn.
    alpha : float, default=0.001
        Level of the sign test: the probability of replacing the plain ELM
        by a candidate that is no better (18 of 20 blocks at 0.1 %). Set
        for a family of decisions, not one: see Notes, rule 3.
    regime_holdout : bool, default=True
        With ``accept="sign_test"``, the candidate must also have the lower
        RMSE on every thermal regime (cooling, soak, heating) present in the
        training run when that regime is held out whole and both networks
        are fitted on the others (Notes, rule 4).
    temperature_column : int, default=0
        Column of X holding the temperature (gyrocomp's drift inputs are
        (T, dT/dt), normalised); the regimes come from its slope, the
        samples taken in time order.
    regime_window : float, default=0.01
        Length of the centred moving mean that smooths the temperature
        before its slope is taken, as a fraction of the samples (at least 3).
    soak_fraction : float, default=0.1
        A sample is soak when its smoothed slope is smaller in magnitude
        than this fraction of the 99th percentile of the magnitudes over
        the run; heating or cooling otherwise, by its sign.
    ridge : float, default=1e-10
        Tikhonov term of every candidate ELM of the search and of the
        deployed candidate (see :class:`ELM`); not of the plain ELM, which
        is ``ELM()`` (Moore-Penrose). See Notes, stability.
    seed : int or None, default=None
        Seeds the split, pymoo's NSGA-II and the ELMs' random weights.

    Attributes
    ----------
    front_ : list of dict
        The non-dominated members of the final population, each with
        ``n_hidden``, ``activation``, ``weight_scale`` (lambda), ``rmse``
        (validation, unit of y) and ``beta_norm`` (||beta||_2 of the ELM
        trained on the training blocks), sorted by ``rmse``.
    candidate_index_ : int
        Index in ``front_`` of the candidate (``pick``).
    best_index_ : int or None
        ``candidate_index_`` when the candidate was accepted; None when the
        plain ELM was kept (``accept``).
    plain_rmse_ : float
        Validation RMSE of the plain individual of the search (``ELM()``'s
        hyper-parameters, ``ridge``, ``elm_seed_``), in the unit of y.
    cv_rmse_ : ndarray, shape (2, 4 * cv_folds)
        Cross-validated RMSE per block (unit of y) of the plain ELM (row 0)
        and of the candidate (row 1), both with ``elm_seed_``'s weights.
    p_value_ : float
        One-sided sign-test p-value of "the candidate is better on more
        blocks than chance", from ``cv_rmse_``.
    regimes_ : list of str
        The thermal regimes present in the training run, in the order of
        ``REGIMES`` (``temperature_column``, ``regime_window``,
        ``soak_fraction``).
    regime_rmse_ : ndarray, shape (2, len(regimes_))
        RMSE (unit of y) on each regime held out whole, the networks
        fitted on the other regimes: plain ELM (row 0), candidate (row 1).
        No columns when the run has a single regime.
    elm_seed_ : int
        The seed every candidate ELM used (common random numbers).
    estimator_ : ELM
        The candidate (with ``ridge``) or the plain ELM (``ELM()``), with
        ``elm_seed_``, refitted on all the samples.
    n_features_in_ : int

    Notes
    -----
    Inputs are used as given (see :class:`ELM`: normalise them first).
    Zhang et al. write the second objective as min ||beta||_2; its square
    has the same Pareto set, and the knee here is computed on ||beta||_2.

    **The pick.** [1] does not say which member of the front it deploys
    (section 3.6 stops at the Pareto set); the natural reading, a knee of
    the whole front deployed as is, is ``rmse_tolerance`` large with
    ``accept="always"``. That knee can be a degenerate network (a few
    hardlim nodes, ||beta|| ~ 1) whose error is several times the best: the
    end of the front with a tiny ||beta|| stretches the normalised RMSE
    axis. Even the least validation RMSE is a poor guide: it is measured
    on one split of a few autocorrelated blocks, and the best of some 600
    candidates on that split is the one that fitted its noise best (issue
    #20: up to 3.5x the plain ELM's held-out error). gyrocomp's rule, ours:

    1. the plain ELM that NSGA-II-ELM is meant to improve (``ELM()``'s
       hyper-parameters with ``elm_seed_``) is one individual of the
       initial population; NSGA-II's elitism keeps the least-RMSE end of
       the front, so the best validation RMSE on the front is at most the
       plain individual's;
    2. the candidate is the knee among the members within
       ``rmse_tolerance`` of that best (the best member when no other lies
       there): the search and its split only nominate;
    3. the candidate replaces the plain ELM only when a blocked K-fold
       cross-validation over all the samples shows a consistent gain: the
       samples are cut into ``4 * cv_folds`` contiguous blocks dealt to the
       folds in turn (each fold spans the run and its temperature range;
       autocorrelated neighbours straddle a fold only at block ends); each
       fold is predicted by both networks fitted on the other folds, with
       ``elm_seed_``'s random weights (a paired comparison: the plain ELM
       exactly as ``ELM(seed=elm_seed_)``, the candidate with ``ridge``); and the
       candidate's mean squared error must be the lower one on
       significantly many blocks, a one-sided sign test at ``alpha``
       (18 of 20 blocks at 0.1 %: p = 211 / 2^20 = 2.0e-4; 17 blocks give
       1.3e-3). The sign test asks nothing of the size or the distribution
       of the block errors, only that the blocks be independent, which
       contiguous blocks of an autocorrelated residual are more nearly
       than samples. **Its level is set for a family of decisions.**
       ``alpha`` bounds the chance that one fit replaces the plain ELM by
       a candidate that is no better; the promise made of the pick
       (issue #20) is about a family, "never worse than 1.1x" over 150
       fits (50 seeds on each of three problems). Over N decisions the
       chance of at least one false acceptance is at most N times the
       test's size (Bonferroni, whatever the dependence between fits): at
       the former 1 % (size 0.59 %, 16 blocks) that bound is 0.89 for
       N = 150, about one false acceptance expected per family, which is
       what the fresh seeds showed; at 0.1 % (size 0.020 %) it is 3 %.
       Any per-fit level at or below 5 % / 150 = 3.3e-4 gives the same 18
       blocks. The price is power: candidates that won 16 or 17 blocks,
       most of them good, are refused and the plain ELM is kept
       (``benchmarks/README.md``). The level was lowered after a false
       acceptance (16 blocks, 1.24x) was seen on the fresh seeds; the
       argument does not use that seed, and new fresh seeds checked it;
    4. and (``regime_holdout``) the candidate must also be the better one
       when each thermal regime of the training run is held out whole:
       leave-one-regime-out, regime by the sign of the smoothed
       temperature slope (cooling, soak, heating; ``soak_fraction``,
       ``regime_window``), both networks fitted on the samples of the other
       regimes as in rule 3, and the candidate's RMSE lower on every regime
       present. Rule 3's folds each span the whole run, so every regime is
       in every training fold: it measures interpolation within the
       training run's own mix of (T, dT/dt), and a deployment that meets
       another mix (a test run heating where training cooled) is outside
       what it sees. Holding a regime out whole makes each network predict
       a regime from the others, the shift a held-out run can bring, and
       the candidate must not lose on any of them. The check can only
       refuse candidates, never add one; it is vacuous on a run with a
       single regime. It is not a significance test (one comparison per
       regime, two or three in all); it is a guard: a candidate that
       extrapolates worse than the plain ELM into any regime is not taken.

    The obvious alternative in the paper's own terms, Pareto dominance of
    the plain ELM in (RMSE, ||beta||_2) (the candidate's ||beta|| no larger
    than the plain ELM's), does not separate the cases: on the sample data
    (``benchmarks/nsga2elm_pick.py``, check seed 1026) the candidate that
    came out 1.8x the plain ELM on the held-out run had ||beta|| 420
    against 1900 on the search's split (800 against 1600 on all samples),
    and the only other candidate taken there, 0.91x, had the larger norm.
    Moore-Penrose ELMs with collinear hidden units carry ||beta|| in the
    1e5-1e6, so the norm says little about extrapolation here.

    **Stability.** The Moore-Penrose solution cuts H's singular values at a
    round-off threshold (:class:`ELM`), so when one lies near it a 1e-12
    change of the inputs moves a candidate's objectives by up to 1e-3
    relative (81 of 300 random candidates on an oven run moved by more
    than 1e-6), NSGA-II takes another path and finds another front (10 of
    15 seeds of ``benchmarks/nsga2elm_pick.py`` with ridge 0). The
    candidates' ridge C = 1e-10 makes beta = V diag(s / (s^2 + C)) U^T y a
    continuous function of the data. C is several hundred times the
    round-off of s^2 (eps * n * max h^2, 1e-13 to 5e-13 for activations
    bounded by 1 and 600-2000 samples); it damps only directions with
    s < 1e-5, those whose Moore-Penrose coefficients round-off decides.
    The objectives then move by at most 1e-9 relative (0 of the 300), and
    the front, the candidate and the pick stay (see the benchmark). The
    plain ELM keeps ridge 0: it is ``ELM()`` exactly, the model the pick
    must not be worse than.

    Rule 4 has limited power where the training run holds little of a
    regime: on the sample data (one heating ramp of some 80 samples) its
    verdict on the candidate it was added for is refused at
    ``soak_fraction`` 0.05 to 0.15 and taken at 0.02, 0.2 and 0.3, a single
    fit's extrapolation into a small regime being erratic. It is a guard,
    not a guarantee.

    Held-out ratios over 150 seen seeds and 50 fresh ones on three
    problems, at each level, with and without rule 4, and the pick's
    stability under 1e-12 input changes: ``benchmarks/results/nsga2elm_pick.json``
    (``benchmarks/nsga2elm_pick.py``, ``benchmarks/README.md``).

    References
    ----------
    .. [1] Z. Zhang et al., "Temperature compensation for a dual-mass MEMS
       gyroscope based on ICEEMDAN-SE-TFPF and NSGA II-ELM", Micromachines
       15, 609 (2024).
    .. [2] K. Deb, A. Pratap, S. Agarwal, T. Meyarivan, "A fast and elitist
       multiobjective genetic algorithm: NSGA-II", IEEE Trans. Evol.
       Comput. 6(2), 182-197 (2002).
    """

    kind = "nsga2elm"
    first_version = 3
    _fitted = (
        "n_features_in_", "front_", "candidate_index_", "best_index_", "plain_rmse_", "cv_rmse_", "p_value_",
        "regimes_", "regime_rmse_", "elm_seed_", "estimator_",
    )

    def __init__(
        self,
        pop_size=40,
        crossover=0.8,
        mutation=0.15,
        n_gen=15,
        hidden_range=(1, 50),
        activations=("sigmoid", "sin", "hardlim", "tribas", "radbas"),
        weight_scale_range=(0.0, 1.0),
        validation_fraction=0.2,
        pick="knee",
        rmse_tolerance=0.02,
        accept="sign_test",
        cv_folds=5,
        alpha=0.001,
        regime_holdout=True,
        temperature_column=0,
        regime_window=0.01,
        soak_fraction=0.1,
        ridge=1e-10,
        seed=None,
    ):
        self.pop_size = pop_size
        self.crossover = crossover
        self.mutation = mutation
        self.n_gen = n_gen
        self.hidden_range = hidden_range
        self.activations = activations
        self.weight_scale_range = weight_scale_range
        self.validation_fraction = validation_fraction
        self.pick = pick
        self.rmse_tolerance = rmse_tolerance
        self.accept = accept
        self.cv_folds = cv_folds
        self.alpha = alpha
        self.regime_holdout = regime_holdout
        self.temperature_column = temperature_column
        self.regime_window = regime_window
        self.soak_fraction = soak_fraction
        self.ridge = ridge
        self.seed = seed

    def fit(self, X: Any, y: Any) -> "NSGA2ELM":
        """Run NSGA-II, keep the front, pick one member and refit it on all data.

        Parameters
        ----------
        X : array_like, shape (n_samples, n_features)
        y : array_like, shape (n_samples,)

        Returns
        -------
        self
        """
        X, y = check_X_y(X, y, min_samples=4)
        self._check_params()
        if self.temperature_column >= X.shape[1]:
            raise InputError(f"NSGA2ELM: `temperature_column` {self.temperature_column} is not among X's {X.shape[1]} columns")
        rng = np.random.default_rng(self.seed)
        train, val = block_split(len(y), self.validation_fraction, rng)
        pymoo_seed, elm_seed = (int(s) for s in rng.integers(0, 2**31 - 1, size=2))
        X_val, y_val = X[val], y[val]
        X_tr, y_tr = X[train], y[train]

        def objectives(n_hidden: int, activation: str, weight_scale: float) -> tuple[float, float]:
            elm = ELM(n_hidden, activation, weight_scale, self.ridge, seed=elm_seed).fit(X_tr, y_tr)
            return rmse(elm.predict(X_val), y_val), elm.beta_norm_

        front = _search(self, objectives, pymoo_seed)
        plain = _plain_elm(self)
        index = _pick(front, self.pick, float(self.rmse_tolerance))
        candidate = {k: front[index][k] for k in plain}
        self.front_ = front
        self.candidate_index_ = index
        self.plain_rmse_ = objectives(**plain)[0]
        plain_ridge, ridge = float(ELM().ridge), float(self.ridge)
        pair = ((plain, plain_ridge), (candidate, ridge))
        self.cv_rmse_ = np.array([cv_rmse(params, X, y, int(self.cv_folds), r, elm_seed) for params, r in pair])
        self.p_value_ = sign_test(self.cv_rmse_)
        labels = regimes(X[:, int(self.temperature_column)], float(self.regime_window), float(self.soak_fraction))
        self.regimes_ = [REGIMES[k + 1] for k in np.unique(labels)] if len(np.unique(labels)) > 1 else []
        self.regime_rmse_ = np.array([regime_rmse(params, X, y, labels, r, elm_seed) for params, r in pair])
        accepted = self.accept == "always" or significant_everywhere(
            self.p_value_, float(self.alpha), self.regime_rmse_ if self.regime_holdout else None
        )
        self.best_index_ = index if accepted else None
        chosen = {**candidate, "ridge": ridge} if accepted else {**plain, "ridge": plain_ridge}
        self.elm_seed_ = elm_seed
        self.estimator_ = ELM(**chosen, seed=elm_seed).fit(X, y)
        self.n_features_in_ = X.shape[1]
        return self

    def _forward(self, X: np.ndarray) -> np.ndarray:
        """The picked ELM's output, in the unit of y."""
        return self.estimator_._forward(X)

    def _check_params(self) -> None:
        owner = "NSGA2ELM"
        check_int(owner, "pop_size", self.pop_size, 2)
        check_float(owner, "crossover", self.crossover, 0.0, 1.0)
        check_float(owner, "mutation", self.mutation, 0.0, 1.0)
        check_int(owner, "n_gen", self.n_gen, 1)
        if not isinstance(self.hidden_range, (tuple, list)) or len(self.hidden_range) != 2:
            raise InputError(f"{owner}: `hidden_range` must be (low, high), got {self.hidden_range!r}")
        low = check_int(owner, "hidden_range", self.hidden_range[0], 1)
        check_int(owner, "hidden_range", self.hidden_range[1], low)
        if not isinstance(self.activations, (tuple, list)) or not self.activations:
            raise InputError(f"{owner}: `activations` must be a non-empty tuple, got {self.activations!r}")
        for name in self.activations:
            check_choice(owner, "activations", name, tuple(ACTIVATIONS))
        if not isinstance(self.weight_scale_range, (tuple, list)) or len(self.weight_scale_range) != 2:
            raise InputError(
                f"{owner}: `weight_scale_range` must be (low, high), got {self.weight_scale_range!r}"
            )
        lo = check_float(owner, "weight_scale_range", self.weight_scale_range[0], 0.0, 1.0)
        check_float(owner, "weight_scale_range", self.weight_scale_range[1], lo, 1.0)
        check_float(owner, "validation_fraction", self.validation_fraction, 0.0, 0.5, low_open=True)
        check_choice(owner, "pick", self.pick, PICKS)
        check_float(owner, "rmse_tolerance", self.rmse_tolerance, 0.0)
        check_choice(owner, "accept", self.accept, ACCEPTS)
        check_int(owner, "cv_folds", self.cv_folds, 2)
        check_float(owner, "alpha", self.alpha, 0.0, 1.0, low_open=True)
        if not isinstance(self.regime_holdout, (bool, np.bool_)):
            raise InputError(f"{owner}: `regime_holdout` must be true or false, got {self.regime_holdout!r}")
        check_int(owner, "temperature_column", self.temperature_column, 0)
        check_float(owner, "regime_window", self.regime_window, 0.0, 1.0)
        check_float(owner, "soak_fraction", self.soak_fraction, 0.0, 1.0)
        check_float(owner, "ridge", self.ridge, 0.0)
        check_seed(owner, self.seed)

    def _encode_fitted(self) -> dict[str, Any]:
        encoded = super()._encode_fitted()
        encoded["estimator_"] = self.estimator_.to_dict()
        return encoded

    def _decode_fitted(self, fitted: dict[str, Any]) -> None:
        owner = "NSGA2ELM"
        self.n_features_in_ = check_int(owner, "n_features_in_", fitted["n_features_in_"], 1)
        front = fitted["front_"]
        if not isinstance(front, list) or not front or not all(isinstance(m, dict) for m in front):
            raise InputError(f"{owner}: `front_` must be a non-empty list of members")
        self.front_ = [dict(member) for member in front]
        self.candidate_index_ = check_int(owner, "candidate_index_", fitted["candidate_index_"], 0, len(front) - 1)
        index = fitted["best_index_"]
        self.best_index_ = None if index is None else check_int(owner, "best_index_", index, 0, len(front) - 1)
        self.plain_rmse_ = check_float(owner, "plain_rmse_", fitted["plain_rmse_"], 0.0)
        self.cv_rmse_ = finite_array(owner, "cv_rmse_", fitted["cv_rmse_"], ndim=2)
        self.p_value_ = check_float(owner, "p_value_", fitted["p_value_"], 0.0, 1.0)
        regimes = fitted["regimes_"]
        if not isinstance(regimes, list) or any(name not in REGIMES for name in regimes) or len(set(regimes)) != len(regimes):
            raise InputError(f"{owner}: `regimes_` must be a list of distinct names among {', '.join(REGIMES)}")
        self.regimes_ = list(regimes)
        self.regime_rmse_ = finite_array(owner, "regime_rmse_", fitted["regime_rmse_"], ndim=2, empty_ok=True)
        self.elm_seed_ = check_seed(owner, fitted["elm_seed_"])
        self.estimator_ = ELM.from_dict(fitted["estimator_"])

    def _check_loaded(self) -> None:
        owner = "NSGA2ELM"
        self._check_params()
        check_shape(owner, "cv_rmse_", self.cv_rmse_, (2, 4 * self.cv_folds))
        check_shape(owner, "regime_rmse_", self.regime_rmse_, (2, len(self.regimes_)))
        if self.temperature_column >= self.n_features_in_:
            raise InputError(f"{owner}: `temperature_column` {self.temperature_column} is not among {self.n_features_in_} inputs")
        if self.best_index_ is not None and self.best_index_ != self.candidate_index_:
            raise InputError(f"{owner}: `best_index_` must be None or `candidate_index_`")
        if not self.estimator_._is_fitted():
            raise InputError(f"{owner}: `estimator_` is not a fitted ELM")
        if self.estimator_.n_features_in_ != self.n_features_in_:
            raise InputError(
                f"{owner}: `estimator_` takes {self.estimator_.n_features_in_} inputs; "
                f"`n_features_in_` is {self.n_features_in_}"
            )


def _search(model: NSGA2ELM, objectives, seed: int) -> list[dict[str, Any]]:
    """NSGA-II over (n_hidden, activation, lambda); the final non-dominated set."""
    from pymoo.algorithms.moo.nsga2 import NSGA2, binary_tournament
    from pymoo.core.mixed import (
        MixedVariableDuplicateElimination,
        MixedVariableMating,
        MixedVariableSampling,
    )
    from pymoo.core.problem import ElementwiseProblem
    from pymoo.core.sampling import Sampling
    from pymoo.core.variable import Choice, Integer, Real
    from pymoo.operators.crossover.sbx import SBX
    from pymoo.operators.crossover.ux import UX
    from pymoo.operators.mutation.pm import PM
    from pymoo.operators.mutation.rm import ChoiceRandomMutation
    from pymoo.operators.repair.rounding import RoundingRepair
    from pymoo.operators.selection.tournament import TournamentSelection
    from pymoo.optimize import minimize

    class ELMProblem(ElementwiseProblem):
        def __init__(self):
            variables = {
                "n_hidden": Integer(bounds=tuple(int(v) for v in model.hidden_range)),
                "activation": Choice(options=list(model.activations)),
                "weight_scale": Real(bounds=tuple(float(v) for v in model.weight_scale_range)),
            }
            super().__init__(vars=variables, n_obj=2)

        def _evaluate(self, x, out, *args, **kwargs):
            out["F"] = list(objectives(int(x["n_hidden"]), str(x["activation"]), float(x["weight_scale"])))

    class WithPlainELM(Sampling):
        """Random individuals, the first replaced by the plain ELM (see NSGA2ELM Notes, rule 1)."""

        def _do(self, problem, n_samples, random_state=None, **kwargs):
            X = MixedVariableSampling()._do(problem, n_samples, random_state=random_state, **kwargs)
            X[0] = _plain_elm(model)
            return X

    p_cross, p_mut = float(model.crossover), float(model.mutation)
    mating = MixedVariableMating(
        selection=TournamentSelection(func_comp=binary_tournament),
        crossover={
            Real: SBX(prob=p_cross),
            Integer: SBX(prob=p_cross, vtype=float, repair=RoundingRepair()),
            Choice: UX(prob=p_cross),
        },
        mutation={
            Real: PM(prob=1.0, prob_var=p_mut),
            Integer: PM(prob=1.0, prob_var=p_mut, vtype=float, repair=RoundingRepair()),
            Choice: ChoiceRandomMutation(prob=1.0, prob_var=p_mut),
        },
        eliminate_duplicates=MixedVariableDuplicateElimination(),
    )
    algorithm = NSGA2(
        pop_size=model.pop_size,
        sampling=WithPlainELM(),
        mating=mating,
        eliminate_duplicates=MixedVariableDuplicateElimination(),
    )
    result = minimize(ELMProblem(), algorithm, ("n_gen", model.n_gen), seed=seed, verbose=False)
    members = [
        {
            "n_hidden": int(x["n_hidden"]),
            "activation": str(x["activation"]),
            "weight_scale": float(x["weight_scale"]),
            "rmse": float(f[0]),
            "beta_norm": float(f[1]),
        }
        for x, f in zip(np.atleast_1d(result.X), np.atleast_2d(result.F))
    ]
    return sorted(members, key=lambda m: (m["rmse"], m["beta_norm"], m["n_hidden"], m["activation"]))


def _plain_elm(model: NSGA2ELM) -> dict[str, Any]:
    """``ELM()``'s defaults as an individual, held inside the search space of `model`.

    The hidden size and lambda are clipped to their ranges; an activation
    outside ``activations`` is replaced by the first candidate.
    """
    plain = ELM()
    low, high = (int(v) for v in model.hidden_range)
    lo, hi = (float(v) for v in model.weight_scale_range)
    activation = plain.activation if plain.activation in model.activations else model.activations[0]
    return {
        "n_hidden": int(np.clip(plain.n_hidden, low, high)),
        "activation": str(activation),
        "weight_scale": float(np.clip(plain.weight_scale, lo, hi)),
    }


def _pick(front: list[dict[str, Any]], how: str, rmse_tolerance: float) -> int:
    """Index of the picked member of a front sorted by RMSE (see ``pick`` and ``rmse_tolerance``)."""
    F = np.array([[m["rmse"], m["beta_norm"]] for m in front])
    F = F[F[:, 0] <= (1.0 + rmse_tolerance) * F[0, 0]]
    if how == "min_rmse" or len(F) == 1:
        return 0
    span = F.max(axis=0) - F.min(axis=0)
    span[span == 0] = 1.0
    distance = np.hypot(*((F - F.min(axis=0)) / span).T)
    return int(np.argmin(distance))  # first minimum: the smaller RMSE on ties
