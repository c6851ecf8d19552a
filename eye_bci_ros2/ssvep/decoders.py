"""
SSVEP decoders: FBCCA (no training), TRCA and ensemble TRCA (from a calibration).

All decoders score a window of filter-bank output, shape (B, n, C) (bands,
samples, channels; :class:`eye_bci_ros2.ssvep.filters.StreamingFilterBank`),
against K stimuli and return K scores, higher = more likely attended.

- FBCCA (Chen et al. 2015): per sub-band the largest canonical correlation
  rho between the EEG and the sine/cosine references of each stimulus; score
  ``sum_m w(m) rho_m^2`` with ``w(m) = m^-1.25 + 0.25``.
- TRCA (Nakanishi et al. 2018): per sub-band and stimulus a spatial filter
  w that maximises the covariance between calibration trials (generalised
  eigenproblem S w = lambda Q w); the score is ``sum_m w(m) r_m``, r the
  correlation between the filtered window and the filtered trial-average
  template.  The ensemble variant applies the filters of all stimuli at once.

Windows and templates are aligned on the stimulus epoch: ``start_s`` is the
time of the window's first sample after the epoch (0 = the window starts at
stimulus onset).  A TRCA template of stimulus k is periodic with 1/f_k, so a
window that starts later is compared with the template from
``start_s mod (1/f_k)`` (nearest sample).
"""

from dataclasses import dataclass, field
import threading
from typing import Dict, Optional, Sequence, Tuple

import numpy as np
from scipy import linalg

from eye_bci_ros2.ssvep.decision import RestModel
from eye_bci_ros2.ssvep.filters import filter_bank_weights, filter_recording
from eye_bci_ros2.ssvep.references import sine_cosine_references

#: Format version of saved TRCA models.
MODEL_VERSION = 2
DECODERS = ('fbcca', 'trca', 'ensemble_trca')


def _check_window(window: np.ndarray, bands: int) -> np.ndarray:
    window = np.asarray(window, dtype=float)
    if window.ndim != 3 or window.shape[0] != bands:
        raise ValueError(f'expected a window of shape ({bands}, n, C), got {window.shape}')
    if window.shape[1] < 2:
        raise ValueError('a window needs at least 2 samples')
    return window


def canonical_correlations(x: np.ndarray, references: np.ndarray) -> np.ndarray:
    """
    Largest canonical correlation between EEG and each reference set.

    :param x: EEG, shape (B, n, C) (any leading batch of sub-bands).
    :param references: shape (K, n, R).
    :returns: rho, shape (B, K), in [0, 1].
    """
    return _correlations_with_basis(x, reference_basis(references))


def reference_basis(references: np.ndarray) -> np.ndarray:
    """Orthonormal basis of each centred reference set, (K, n, R) (cacheable)."""
    y = references - references.mean(axis=1, keepdims=True)
    return np.linalg.qr(y)[0]


#: Directions of a window's channel space with less than this share of its largest
#: variance are left out of the canonical correlations (linearly dependent channels,
#: e.g. an average reference): they would correlate with anything.
RANK_FLOOR = 1e-10


def _correlations_with_basis(x: np.ndarray, qy: np.ndarray) -> np.ndarray:
    """
    Canonical correlations of x (B, n, C) with orthonormal bases qy (K, n, R).

    x is whitened through its C x C covariance (eigendecomposition) rather than a
    QR of the n x C window: the same correlations, but a matrix product instead of
    a Householder factorisation of a 2000 x 32 window at 1000 Hz (most of the
    decoder's CPU before).
    """
    x = x - x.mean(axis=1, keepdims=True)
    k, n, r = qy.shape
    gram = np.swapaxes(x, 1, 2) @ x  # (B, C, C)
    values, vectors = np.linalg.eigh(gram)
    keep = values > RANK_FLOOR * values[:, -1:]
    scale = np.where(keep, 1.0 / np.sqrt(np.where(keep, values, 1.0)), 0.0)
    # (B, C, n) @ (n, K R): one BLAS product instead of an einsum.
    flat = np.moveaxis(qy, 1, 0).reshape(n, k * r)
    product = np.swapaxes(vectors, 1, 2) @ (np.swapaxes(x, 1, 2) @ flat)
    product = (scale[:, :, None] * product).reshape(x.shape[0], x.shape[2], k, r)
    rho = np.linalg.svd(np.moveaxis(product, 2, 1), compute_uv=False)[..., 0]
    return np.clip(rho, 0.0, 1.0)


@dataclass
class FbccaDecoder:
    """
    Filter-bank CCA: no training.

    :param frequencies: stimulus frequencies, Hz, shape (K,).
    :param rate: sampling rate, Hz.
    :param bands: sub-bands of the window (as the filter bank).
    :param harmonics: harmonics in the references.
    """

    frequencies: Sequence[float]
    rate: float
    bands: int = 5
    harmonics: int = 5
    _basis: dict = field(default_factory=dict, init=False, repr=False)

    def scores(self, window: np.ndarray, start_s: float = 0.0) -> np.ndarray:
        """Return the K scores of a window (B, n, C); ``start_s`` is unused (no phase)."""
        window = _check_window(window, self.bands)
        n = window.shape[1]
        basis = self._basis.get(n)
        if basis is None:
            if len(self._basis) > 8:  # a sliding window has one length; keep a few
                self._basis.clear()
            basis = self._basis[n] = reference_basis(sine_cosine_references(
                self.frequencies, self.rate, n, self.harmonics))
        rho = _correlations_with_basis(window, basis)
        return filter_bank_weights(self.bands) @ (rho ** 2)


#: Frequencies at which the FBCCA null is measured on white noise, Hz (the statistic is
#: a ratio to the option's own neighbourhood: its null changes little over the stimulus
#: range, more towards 40 Hz).  Several per window: the window's QR (n x C) is the cost,
#: a probe only adds references.
NULL_PROBES_HZ = tuple(float(f) for f in range(9, 24, 2))
#: White-noise windows per window length for the FBCCA null (x 8 probes: its standard
#: deviation within ~4 %).  The cost is FBCCA on these windows, once per stream set-up and
#: count of usable channels: 0.1-0.4 s of CPU at 256 Hz x 8 channels, seconds at 1000 Hz x 32.
NULL_WINDOWS = 50
#: A calibration is refused when its left-out trials do not match their own template
#: better than the null: their mean z (each trial against its stimulus's template made
#: without it) is below this many standard errors (1 / sqrt(trials)), p ~ 3e-7: real
#: recordings of free-running LEDs pass 3 standard errors in 3 of 32 calibrations.
REPEAT_Z = 5.0
#: Window lengths of a rest model are at most this far apart, s (interpolated between:
#: the FBCCA null's spread changes by ~10 % from 1 to 2 s, which moves the decisions).
NULL_STEP_S = 0.5


def sideband_hz(min_window_s: float) -> float:
    """
    Distance of an option's sidebands from its frequency, Hz: ``1 / min_window_s``.

    The first zero of the shortest window's spectral kernel, so even that
    window's response to the option does not leak into its sidebands (a
    sideband may fall on another option: attending that one then only lowers
    this one's evidence).
    """
    return 1.0 / float(min_window_s)


#: Sidebands on each side of an option, at 1, 2, ... x :func:`sideband_hz`: their
#: (geometric) mean is the statistic's denominator, so more of them make it less noisy
#: (two per side: on the real recordings 13 more right choices than with one,
#: docs/ssvep.md; further out the neighbourhood would stop being the option's own).
SIDEBANDS_PER_SIDE = 2


def with_sidebands(frequencies: Sequence[float], delta: float) -> np.ndarray:
    """
    Return the K frequencies, then their sidebands, ((1 + 2 S) K,), Hz.

    The sidebands, S = :data:`SIDEBANDS_PER_SIDE`: each frequency minus
    ``delta``, then each plus it, then minus and plus ``2 delta``, ...
    """
    f = np.asarray(frequencies, dtype=float)
    return np.concatenate([f] + [f + sign * j * delta for j in range(1, SIDEBANDS_PER_SIDE + 1)
                                 for sign in (-1.0, 1.0)])


def sideband_statistic(scores: np.ndarray) -> np.ndarray:
    """
    FBCCA evidence statistic: log of each option's score over its sidebands' geometric mean.

    The geometric mean is the straight line through the sidebands' log scores
    (least squares against frequency: they lie symmetrically around the option)
    evaluated at the option, so it follows a log spectrum that slopes across
    the neighbourhood (1/f, an alpha rhythm's flank) as the EEG's does.  The
    arithmetic mean lies above that line by the sidebands' spread (exp is
    convex), the more the steeper the slope: it lowered the evidence of options
    whose lower sidebands are strong (near the alpha band) on real EEG
    (docs/ssvep.md).

    :param scores: FBCCA scores at :func:`with_sidebands` frequencies, ((1 + 2 S) K,).
    :returns: (K,); about 0 where the spectrum is smooth (noise, the alpha
        rhythm's flank), large at a narrow-band response.
    """
    logs = np.log(np.maximum(np.asarray(scores, dtype=float), 1e-12))
    k = len(logs) // (1 + 2 * SIDEBANDS_PER_SIDE)
    return logs[:k] - logs[k:].reshape(-1, k).mean(axis=0)


def null_windows(min_window_s: float, window_s: float) -> Tuple[float, ...]:
    """Window lengths a rest model is measured at, s."""
    count = max(1, int(np.ceil((window_s - min_window_s) / NULL_STEP_S - 1e-9)))
    return tuple(float(w) for w in np.linspace(min_window_s, window_s, count + 1))


#: A key of :func:`fbcca_null`: (rate, channels, bands, harmonics, band, notch_hz,
#: windows_s, delta, frequencies).
NullKey = Tuple[float, int, int, int, Tuple[float, float], float, Tuple[float, ...], float,
                Tuple[float, ...]]
#: FBCCA nulls measured in this process, by key (kept: a handful of settings per process).
_NULLS: Dict[NullKey, RestModel] = {}
#: Nulls being measured in the background, by key.
_MEASURING: Dict[NullKey, threading.Thread] = {}
_NULLS_LOCK = threading.Lock()


def fbcca_null(rate: float, channels: int, bands: int, harmonics: int,
               band: Tuple[float, float], notch_hz: float, windows_s: Tuple[float, ...],
               delta: float, frequencies: Tuple[float, ...] = ()) -> RestModel:
    """
    Measure the FBCCA sideband statistic of an unattended option on white noise.

    Seeded, so the same settings give the same null.  The statistic compares
    an option with its own neighbourhood, so its null depends on the window
    length, channels and harmonics (degrees of freedom), hardly on the EEG's
    spectrum or size: measured on real rest EEG it matches (docs/ssvep.md).
    Its spread is pooled over :data:`NULL_PROBES_HZ`; its mean is also measured
    at each of ``frequencies`` (the offered options, in the same noise
    windows): there the filters shift it (an option whose lower sidebands
    fall on the filter bank's lower edge, e.g. 8 Hz: +0.14, 0.7 standard
    deviations; one whose harmonic falls on the line notch, 10 Hz: -0.17).
    Measured once per process and settings (seconds at 1000 Hz x 32 channels):
    a live decoder asks :func:`fbcca_null_soon` instead, which never waits.
    """
    key = _null_key(rate, channels, bands, harmonics, band, notch_hz, windows_s, delta,
                    frequencies)
    with _NULLS_LOCK:
        known = _NULLS.get(key)
    if known is None:
        known = _measure_null(*key)
        with _NULLS_LOCK:
            known = _NULLS.setdefault(key, known)
    return known


def fbcca_null_soon(rate: float, channels: int, bands: int, harmonics: int,
                    band: Tuple[float, float], notch_hz: float, windows_s: Tuple[float, ...],
                    delta: float, frequencies: Tuple[float, ...] = ()) -> Optional[RestModel]:
    """
    :func:`fbcca_null` if already measured, else None and its measurement started.

    The measurement runs in a daemon thread (numpy's factorisations release
    the GIL, so a decision step in the meantime is not held up by it), one
    per settings; the caller asks again at its next step.
    """
    key = _null_key(rate, channels, bands, harmonics, band, notch_hz, windows_s, delta,
                    frequencies)
    with _NULLS_LOCK:
        if key in _NULLS:
            return _NULLS[key]
        if key not in _MEASURING or not _MEASURING[key].is_alive():
            thread = threading.Thread(target=fbcca_null, args=key, daemon=True,
                                      name='fbcca-null')
            _MEASURING[key] = thread
            thread.start()
    return None


def _null_key(rate, channels, bands, harmonics, band, notch_hz, windows_s, delta,
              frequencies) -> NullKey:
    return (float(rate), int(channels), int(bands), int(harmonics),
            (float(band[0]), float(band[1])), float(notch_hz),
            tuple(float(w) for w in windows_s), float(delta),
            tuple(float(f) for f in frequencies))


def _measure_null(rate: float, channels: int, bands: int, harmonics: int,
                  band: Tuple[float, float], notch_hz: float, windows_s: Tuple[float, ...],
                  delta: float, frequencies: Tuple[float, ...]) -> RestModel:
    """Measure :func:`fbcca_null` (no cache)."""
    rng = np.random.default_rng(20161)
    hop = int(round(max(windows_s) * rate / 2))  # windows overlap by half: less to filter
    start = int(round(3.0 * rate))  # past the filters' settle time
    noise = rng.standard_normal((start + (NULL_WINDOWS + 1) * hop, channels))
    filtered = filter_recording(noise, rate, bands, band, notch_hz)
    probes = len(NULL_PROBES_HZ)
    decoder = FbccaDecoder(with_sidebands(NULL_PROBES_HZ + tuple(frequencies), delta), rate,
                           bands, harmonics)
    samples, option_means = [], []
    for length in windows_s:
        n = int(round(length * rate))
        values = np.array([sideband_statistic(decoder.scores(
            filtered[:, start + i * hop:start + i * hop + n])) for i in range(NULL_WINDOWS)])
        samples.append(values[:, :probes].ravel())
        option_means.append(tuple(values[:, probes:].mean(axis=0).tolist()))
    pooled = RestModel.measure(windows_s, samples, 'white noise')
    if not frequencies:
        return pooled
    return RestModel(pooled.windows_s, pooled.mean, pooled.std, pooled.source,
                     tuple(option_means))


def trca_filter(trials: np.ndarray) -> np.ndarray:
    """
    TRCA spatial filter of one stimulus in one sub-band.

    :param trials: shape (T, n, C), T >= 2 trials time-locked to the onset.
    :returns: w, shape (C,), unit norm, the eigenvector of the largest
        eigenvalue of S w = lambda Q w (S: summed covariances between
        different trials; Q: covariance of the concatenated trials).
    """
    trials = np.asarray(trials, dtype=float)
    if trials.ndim != 3 or trials.shape[0] < 2:
        raise ValueError(f'TRCA needs at least 2 trials of shape (n, C), got {trials.shape}')
    centred = trials - trials.mean(axis=1, keepdims=True)
    total = centred.sum(axis=0)
    s = total.T @ total - np.einsum('tnc,tnd->cd', centred, centred)
    concatenated = trials.reshape(-1, trials.shape[2])
    concatenated = concatenated - concatenated.mean(axis=0)
    q = concatenated.T @ concatenated
    q += 1e-9 * np.trace(q) / len(q) * np.eye(len(q))
    _, vectors = linalg.eigh(s, q)
    w = vectors[:, -1]
    return w / np.linalg.norm(w)


def _correlation(a: np.ndarray, b: np.ndarray) -> float:
    a = a.ravel() - a.mean()
    b = b.ravel() - b.mean()
    denominator = np.sqrt((a @ a) * (b @ b))
    return float(a @ b / denominator) if denominator > 0 else 0.0


@dataclass
class TrcaModel:
    """
    A fitted (ensemble) TRCA decoder and the settings it was fitted with.

    :param labels: stimulus labels, shape (K,).
    :param frequencies: Hz, shape (K,); ``phases`` rad, shape (K,).
    :param rate: sampling rate, Hz.
    :param filters: spatial filters W, shape (B, K, C).
    :param templates: trial averages, shape (K, B, L, C).
    :param channels: channel names the model was fitted on, (C,).
    :param band: preprocessing pass band, Hz; ``notch_hz`` line notch, Hz.
    :param ensemble: score with every stimulus's filter at once.
    :param template_start_s: the templates start this long after the
        stimulus epoch, s (the calibration left out the response's build-up).
    :param rest: the score of an option nobody attends, by window length
        (measured on the calibration's other options' and rest trials); a
        model without it cannot decide (calibrate again).
    """

    labels: Tuple[str, ...]
    frequencies: np.ndarray
    phases: np.ndarray
    rate: float
    filters: np.ndarray
    templates: np.ndarray
    channels: Tuple[str, ...]
    band: Tuple[float, float] = (6.0, 90.0)
    notch_hz: float = 50.0
    ensemble: bool = True
    template_start_s: float = 0.0
    rest: Optional[RestModel] = None
    _weights: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        """Check shapes and precompute the sub-band weights."""
        self.labels = tuple(str(label) for label in self.labels)
        self.channels = tuple(str(name) for name in self.channels)
        self.frequencies = np.asarray(self.frequencies, dtype=float)
        self.phases = np.asarray(self.phases, dtype=float)
        self.filters = np.asarray(self.filters, dtype=float)
        self.templates = np.asarray(self.templates, dtype=float)
        k = len(self.labels)
        if (self.frequencies.shape != (k,) or self.phases.shape != (k,)
                or self.filters.ndim != 3 or self.filters.shape[1] != k
                or self.templates.ndim != 4 or self.templates.shape[0] != k
                or self.templates.shape[1] != self.filters.shape[0]
                or self.templates.shape[3] != self.filters.shape[2]
                or len(self.channels) != self.filters.shape[2]):
            raise ValueError('inconsistent TRCA model: labels, frequencies, phases, filters '
                             f'{self.filters.shape} and templates {self.templates.shape} '
                             'do not agree')
        self._weights = filter_bank_weights(self.bands)

    @property
    def bands(self) -> int:
        """Return the number of sub-bands B."""
        return self.filters.shape[0]

    @property
    def template_s(self) -> float:
        """Return the template length, s (the longest useful window)."""
        return self.templates.shape[2] / self.rate

    @classmethod
    def fit(cls, epochs: np.ndarray, targets: Sequence[int], labels: Sequence[str],
            frequencies: Sequence[float], phases: Sequence[float], rate: float,
            channels: Sequence[str], ensemble: bool = True,
            rest_epochs: Optional[np.ndarray] = None, min_window_s: float = 0.5,
            require_repeat: bool = True, **settings) -> 'TrcaModel':
        """
        Fit from calibration trials, with the null of its scores.

        :param epochs: filter-bank output of each trial from ``template_start_s``
            (in ``settings``) after the stimulus onset, shape (T, B, L, C).
        :param targets: index of the attended stimulus of each trial, (T,).
        :param labels: stimulus labels (K,); ``frequencies``, ``phases`` (K,).
        :param rest_epochs: trials in which nothing was attended, (R, B, L, C).
        :param min_window_s: shortest window the null is measured at, s.
        :param require_repeat: refuse trials that do not repeat (False: only
            for showing what such a model does).
        :param settings: ``band``, ``notch_hz`` used for the filtering.
        :raises ValueError: when a stimulus has fewer than 2 trials, or when the
            trials of the stimuli do not repeat (the response is not phase-locked
            to the onsets: TRCA cannot learn it), with why.
        """
        epochs = np.asarray(epochs, dtype=float)
        targets = np.asarray(targets, dtype=int)
        if epochs.ndim != 4 or len(targets) != len(epochs):
            raise ValueError(f'epochs must be (T, B, L, C) with one target per trial, got '
                             f'{epochs.shape} and {len(targets)} targets')
        k = len(labels)
        _, bands, length, count = epochs.shape
        filters = np.zeros((bands, k, count))
        templates = np.zeros((k, bands, length, count))
        for target in range(k):
            chosen = epochs[targets == target]
            if len(chosen) < 2:
                raise ValueError(f"stimulus '{labels[target]}' has {len(chosen)} calibration "
                                 f'trials; TRCA needs at least 2 per stimulus')
            templates[target] = chosen.mean(axis=0)
            for band in range(bands):
                filters[band, target] = trca_filter(chosen[:, band])
        model = cls(tuple(labels), np.asarray(frequencies, float), np.asarray(phases, float),
                    float(rate), filters, templates, tuple(channels), ensemble=ensemble,
                    **settings)
        windows = null_windows(min(min_window_s, model.template_s), model.template_s)
        null, repeat = model._calibration_scores(epochs, targets, rest_epochs, windows)
        rest = RestModel.measure(windows, null, 'calibration')
        z = rest.z(repeat, windows[-1])
        if require_repeat and z.mean() * np.sqrt(len(z)) < REPEAT_Z:
            raise ValueError(
                'the calibration trials do not repeat: left-out trials match their own '
                "stimulus's template no better than the others' (mean z "
                f'{z.mean():.2f} over {len(z)} trials, need '
                f'{REPEAT_Z / np.sqrt(len(z)):.2f}).  TRCA needs stimuli whose phase is the '
                'same at every trial onset (a screen stimulus drawn frame by frame from the '
                'onset); with '
                'free-running flicker (LEDs) use the fbcca decoder')
        return cls(model.labels, model.frequencies, model.phases, model.rate, filters,
                   templates, model.channels, ensemble=ensemble, rest=rest, **settings)

    def _calibration_scores(self, epochs: np.ndarray, targets: np.ndarray,
                            rest_epochs: Optional[np.ndarray], windows: Sequence[float]):
        """
        Scores of unattended templates by window length, and left-out own-template scores.

        :returns: ``(null, repeat)``: per window length the scores of each trial
            against the other stimuli's templates (and of each rest trial against
            all), and each trial's score against its own stimulus's template
            made without it, at the longest window, (T,).
        """
        null = []
        for length in windows:
            n = int(round(length * self.rate))
            start = self.template_start_s
            values = [np.delete(self.scores(trial[:, :n], start), target)
                      for trial, target in zip(epochs, targets)]
            values += [self.scores(trial[:, :n], start) for trial in
                       (rest_epochs if rest_epochs is not None else [])]
            null.append(np.concatenate(values))
        repeat = np.zeros(len(epochs))
        for index, (trial, target) in enumerate(zip(epochs, targets)):
            # Template and spatial filter both made without the trial: a filter fitted on
            # it would find chance alignments of random-phase trials and look like repetition.
            others = epochs[(targets == target) & (np.arange(len(epochs)) != index)]
            filters = self.filters.copy()
            for band in range(self.bands if len(others) >= 2 else 0):  # 2 trials: keep it
                filters[band, target] = trca_filter(others[:, band])
            repeat[index] = self._score(trial, others.mean(axis=0), target, filters)
        return null, repeat

    def _score(self, window: np.ndarray, template: np.ndarray, target: int,
               filters: Optional[np.ndarray] = None) -> float:
        """Score of a window (B, n, C) against one template (B, m, C) of ``target``."""
        filters = self.filters if filters is None else filters
        part = window[:, :template.shape[1]]
        rho = np.zeros(self.bands)
        for band in range(self.bands):
            w = (filters[band].T if self.ensemble else filters[band, target][:, None])
            rho[band] = _correlation(part[band] @ w, template[band, :part.shape[1]] @ w)
        return float(self._weights @ rho)

    def _template(self, target: int, start_s: float, samples: int) -> np.ndarray:
        """Template of ``target`` from ``start_s`` after onset, (B, m, C), m <= samples."""
        period = 1.0 / self.frequencies[target]
        since = start_s - self.template_start_s
        offset_s = since - np.floor(since / period) * period
        offset = int(round(offset_s * self.rate))
        length = self.templates.shape[2]
        if offset >= length:
            offset = 0
        return self.templates[target, :, offset:offset + samples]

    def scores(self, window: np.ndarray, start_s: float = 0.0) -> np.ndarray:
        """
        Return the K scores of a window (B, n, C) that starts ``start_s`` after the epoch.

        Only the part of the window the template covers is used.
        """
        window = _check_window(window, self.bands)
        if window.shape[2] != self.filters.shape[2]:
            raise ValueError(f'the model was fitted on {self.filters.shape[2]} channels '
                             f'({", ".join(self.channels)}), the window has {window.shape[2]}')
        return np.array([self._score(window, self._template(target, start_s, window.shape[1]),
                                     target) for target in range(len(self.labels))])

    def save(self, path: str) -> None:
        """Write the model to ``path`` (.npz, no pickles)."""
        np.savez(path, version=MODEL_VERSION, labels=np.array(self.labels, dtype=str),
                 frequencies=self.frequencies, phases=self.phases, rate=self.rate,
                 filters=self.filters, templates=self.templates,
                 channels=np.array(self.channels, dtype=str),
                 band=np.array(self.band, dtype=float), notch_hz=self.notch_hz,
                 ensemble=self.ensemble, template_start_s=self.template_start_s,
                 **(self.rest.as_arrays() if self.rest else {}))

    @classmethod
    def load(cls, path: str, ensemble: Optional[bool] = None) -> 'TrcaModel':
        """
        Read a model saved by :meth:`save`.

        :param ensemble: override the scoring variant (None = as saved).
        :raises ValueError: for a missing, unreadable or inconsistent file.
        """
        try:
            with np.load(path, allow_pickle=False) as data:
                if int(data['version']) != MODEL_VERSION:
                    raise ValueError(f"model version {int(data['version'])}, expected "
                                     f'{MODEL_VERSION}')
                model = cls(tuple(data['labels'].tolist()), data['frequencies'],
                            data['phases'], float(data['rate']), data['filters'],
                            data['templates'], tuple(data['channels'].tolist()),
                            band=tuple(data['band'].tolist()),
                            notch_hz=float(data['notch_hz']),
                            ensemble=bool(data['ensemble']) if ensemble is None else ensemble,
                            template_start_s=float(data['template_start_s']),
                            rest=(RestModel.from_arrays(data) if 'rest_mean' in data
                                  else None))
        except (OSError, KeyError, ValueError, EOFError) as error:
            raise ValueError(f"cannot read TRCA model '{path}': {error}") from None
        return model
