"""Monte-Carlo accuracy of every estimator against the trainer's truth and the Cramér–Rao bound.

Run: ``python3 bench/accuracy.py [--runs 200] [--presets first-order,second-order,third-order]
[--cases white,realistic] [--jobs 2] [--scheduler tcp://host:8786]``: the runs go through
``motorid batch``'s engine (:func:`motorid.batch.parallel_map`: joblib ``loky`` processes with one
BLAS thread each, or the workers of a Dask scheduler).

Presets: the trainer's ``first-order``, ``second-order``, ``third-order``, ``electrical-7ms``
(a 7 ms electrical pole near the 4 ms sampling), ``underdamped`` (a complex pair, damping 0.81);
and the real set-ups of
:mod:`motorid.trainer.realsetups` (``fast-tbs1000``, ``pwm-encoder``, ``daq-deadtime``), each
written to disk and read back as a user's files, identified with default options and the
user's ``--step-volts``; their truth is the incremental gain and the mean residence time
(τ by moments + dead time + sensor lag), compared with the estimate's τ + fitted dead time
(their ``realistic`` case only: the files are what the set-up writes).

Cases (paper's 4 ms sampling, 5.92 V step, position + velocity + current captures):
- ``white``: the linearised trainer (no dead-zone, friction nonlinearity, rails), no
  quantisation, white Gaussian noise of ``--sigma`` volts on every channel;
- ``realistic``: the full trainer: 8-bit quantisation, tacho ripple, PWM current noise,
  stick-slip friction, dead-zone, wrap glitches.

Methods: the paper's pinv (reduced state, 100 ms, five-point: as published), the paper's
Markov method (``markov``: Taylor basis, as published) and its Laguerre-basis form
(``markov-laguerre``), the classic 63 % method, motorid's ``oe`` (order auto), ``srivc``, ``auto``;
peers run in the same process: python-control's ERA on the differenced step response
(converted to continuous time), a ``scipy.optimize.curve_fit`` of ``k(1 − e^{−t/τ})``, and
SIPPY's N4SID (``sippy-unipi``) when it imports.

The truth of the ``realistic`` case is what its step can show: the DC gain times
``1 − offset/step`` and the residence time of the noise-free step response with the friction
and dead-zone (:func:`motorid.trainer.step_residence_time`).

Printed per preset × case × method: bias and RMSE of the DC gain and of the dominant time
constant τ (method of moments, ``Σ1/p − Σ1/z``), RMSE/CRLB (white case), the fraction of runs
with the right order, 95 %-interval coverage, failures and the median time per run.
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings
from dataclasses import replace

import control
import numpy as np
import scipy.linalg
import scipy.optimize

from motorid.conditioning.pipeline import ConditioningSettings, condition_experiment
from motorid.identification.pipeline import IdentifySettings, identify_conditioned
from motorid.trainer import preset, run_experiment, step_residence_time

#: The true velocity-TF order of each preset (number of poles that matter).
TRUE_ORDER = {"first-order": 1, "second-order": 2, "third-order": 3, "electrical-7ms": 2, "underdamped": 2}
#: The trainer presets' step, V (the paper's).
STEP_VOLTS = 5.92
#: Presets written to files by motorid.trainer.realsetups (read back as a user's captures).
REAL_SETUP_PRESETS = ("fast-tbs1000", "pwm-encoder", "daq-deadtime")
#: Methods that run on the real-setup presets (the rest assume the paper's three captures).
REAL_SETUP_METHODS = ("pinv", "markov-laguerre", "classic", "oe", "srivc", "auto", "peer:curve_fit")


METHODS = ("pinv", "markov", "markov-laguerre", "classic", "oe", "srivc", "auto", "auto:velocity", "peer:era",
           "peer:curve_fit", "peer:n4sid")
#: ``METHOD:velocity`` runs METHOD on the velocity capture alone (the others left out): the
#: reference for whether the other captures add bias.
#: Bench method names that are ``motorid`` methods with settings: ``markov`` stays the paper's
#: Taylor procedure as published; ``markov-laguerre`` is its Laguerre-basis form.
METHOD_SETTINGS = {"markov": {"method": "markov", "markov_basis": "taylor"},
                   "markov-laguerre": {"method": "markov", "markov_basis": "laguerre"}}


def first_order_of(num, den) -> tuple[float, float]:
    num, den = np.atleast_1d(num).astype(float), np.atleast_1d(den).astype(float)
    dc = float(num[-1] / den[-1])
    tau = float(np.real(np.sum(-1 / np.roots(den)) - (np.sum(-1 / np.roots(num)) if num.size > 1 else 0.0)))
    return dc, tau


def visible_tau(tf, dt: float) -> float:
    """Dominant time constant by moments (``Σ1/p − Σ1/z``) of the poles and zeros slower than
    half a sample, ``|p| < 2/dt``.

    Faster ones (the first-order preset's 0.5 ms electrical pole) are not seen by 4 ms
    samples: they act as a lag of ``1/p``.  The CRLB's model leaves them out (its capture
    shifts take the lag up); the estimates are compared with the whole truth's moments
    (:func:`residence_tau`), since a scope capture's step instant is fixed to its sample
    interval and the lag then stays in τ + dead time, where it belongs.
    """
    num = np.atleast_1d(np.squeeze(tf.num[0][0])).astype(float)
    den = np.atleast_1d(np.squeeze(tf.den[0][0])).astype(float)
    poles = [p for p in np.roots(den) if abs(p) < 2.0 / dt]
    zeros = [z for z in np.roots(num) if abs(z) < 2.0 / dt] if num.size > 1 else []
    tau = np.sum(-1.0 / np.array(poles)) - (np.sum(-1.0 / np.array(zeros)) if zeros else 0.0)
    return float(np.real(tau))


def experiment(name: str, case: str, seed: int, sigma: float):
    if case == "white":
        cfg = replace(preset(name).ideal(), noise_v=sigma)
        return run_experiment(config=cfg, seed=seed, quantised=False, validation=False, step_volts=STEP_VOLTS)
    return run_experiment(config=preset(name), seed=seed, validation=False, step_volts=STEP_VOLTS)


def peer_era(cond, order):
    t, v = cond.time_s, cond.outputs["velocity"]
    dt = float(t[1] - t[0])
    markov = np.diff(np.r_[0.0, v]) / cond.step_volts / dt  # python-control's impulse convention
    sysd, _ = control.eigensys_realization(markov.reshape(1, 1, -1), r=order, dt=dt)
    n = sysd.nstates
    aug = np.eye(n + 1)
    aug[:n, :n], aug[:n, n:] = sysd.A, sysd.B
    log = np.real(scipy.linalg.logm(aug)) / dt
    sysc = control.ss(log[:n, :n], log[:n, n:], sysd.C, sysd.D)
    tf = control.ss2tf(sysc)
    return (*first_order_of(np.squeeze(tf.num[0][0]), np.squeeze(tf.den[0][0])), order)


def peer_curve_fit(cond):
    t, v = cond.full_time_s, cond.full_outputs["velocity"]
    u = cond.step_volts
    f = lambda tt, k, tau: k * u * (1 - np.exp(-tt / tau))  # noqa: E731
    (k, tau), _ = scipy.optimize.curve_fit(f, t, v, p0=[v[-1] / u, 0.3 * t[-1] / 5])
    return float(k), float(tau), 1


def peer_n4sid(cond, order):
    from sippy_unipi import system_identification

    t, v = cond.time_s, cond.outputs["velocity"]
    dt = float(t[1] - t[0])
    u = np.full(t.size, cond.step_volts)
    u[0] = 0.0
    sysid = system_identification(v, u, "N4SID", SS_fixed_order=order, tsample=dt)
    sysd = control.ss(sysid.A, sysid.B, sysid.C, sysid.D, dt)
    dc = float(np.real(control.dcgain(sysd)))
    poles_c = np.log(np.asarray(control.poles(sysd), dtype=complex)) / dt
    tau = float(np.real(np.sum(-1 / poles_c)))
    return dc, tau, order


def real_setup_run(name: str, seed: int, methods):
    """One real-setup recording: written, read back, identified as a user would (default
    options, the user's --step-volts); τ compared as τ + fitted dead time."""
    import tempfile
    from pathlib import Path

    from motorid.trainer.realsetups import write_real_setup

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        rec = write_real_setup(name, Path(tmp) / "rec", seed=seed)
        cond = condition_experiment(rec.read_captures(), ConditioningSettings(), step_volts=rec.step_volts)
        for method in methods:
            if method not in REAL_SETUP_METHODS:
                continue
            t0 = time.perf_counter()
            try:
                if method == "peer:curve_fit":
                    dc, tau, order = peer_curve_fit(cond)
                    ci = None
                else:
                    options = METHOD_SETTINGS.get(method, {"method": method})
                    m = identify_conditioned(cond, IdentifySettings(**options)).model
                    fo = m.first_order()
                    dc, tau = fo.dc_gain, fo.time_constant_s + m.delay_s
                    order = len([p for p in m.poles() if abs(p) > 1e-9])
                    u = m.uncertainty
                    ci = None
                    if u:
                        # residence time τ + dead time: the delay's std added in quadrature
                        sd = float(np.hypot(u["time_constant"]["std"], u.get("delay", {}).get("std", 0.0)))
                        ci = (u["dc_gain"]["ci95"], u["residence_time_s"]["ci95"] if "residence_time_s" in u
                              else (tau - 1.96 * sd, tau + 1.96 * sd))
                out[method] = {"dc": dc, "tau": tau, "order": order, "ci": ci,
                               "time": time.perf_counter() - t0, "failed": None}
            except Exception as exc:
                out[method] = {"failed": f"{type(exc).__name__}: {exc}"[:120], "time": time.perf_counter() - t0}
    return name, "realistic", seed, rec.truth.dc_gain, rec.truth.residence_time_s, out, None


def one_run(args):
    name, case, seed, sigma, methods = args
    if name in REAL_SETUP_PRESETS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return real_setup_run(name, seed, methods)
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        exp = experiment(name, case, seed, sigma)
        caps = dict(exp.captures)
        paper = ConditioningSettings(sample_interval_s=0.1)  # the paper's 100 ms, as published
        cond_paper = condition_experiment(caps, paper)
        cond_fine = condition_experiment(caps, ConditioningSettings(sample_interval_s=None))
        cond_velocity = None
        for method in methods:
            t0 = time.perf_counter()
            try:
                if method == "peer:era":
                    dc, tau, order = peer_era(cond_paper, TRUE_ORDER.get(name, 2))
                    ci = None
                elif method == "peer:curve_fit":
                    dc, tau, order = peer_curve_fit(cond_fine)
                    ci = None
                elif method == "peer:n4sid":
                    dc, tau, order = peer_n4sid(cond_paper, TRUE_ORDER.get(name, 2))
                    ci = None
                else:
                    order_opt = 2 if method == "pinv" else "auto"  # pinv as published: [θ, θ̇]
                    cond = cond_paper if method in ("pinv",) else cond_fine
                    if method.endswith(":velocity"):
                        if cond_velocity is None:
                            cond_velocity = condition_experiment({"velocity": caps["velocity"]},
                                                                 ConditioningSettings(sample_interval_s=None))
                        cond = cond_velocity
                    kw = METHOD_SETTINGS.get(method, {"method": method.split(":")[0]})
                    m = identify_conditioned(cond, IdentifySettings(**kw, order=order_opt)).model
                    fo = m.first_order()
                    # a fitted dead time stands in for the poles faster than a few samples: the
                    # moments τ of G·e^(−sθ) is τ + θ (as for the real set-ups below)
                    dc, tau = fo.dc_gain, fo.time_constant_s + m.delay_s
                    order = len([p for p in m.poles() if abs(p) > 1e-9])
                    if "velocity" in m.outputs and "position" in m.outputs and m.method in ("pinv",):
                        order = m.order
                    u = m.uncertainty
                    ci = None
                    if u:
                        ci = (u["dc_gain"]["ci95"], u.get("residence_time_s", u["time_constant"])["ci95"])
                out[method] = {"dc": dc, "tau": tau, "order": order, "ci": ci,
                               "time": time.perf_counter() - t0, "failed": None}
            except Exception as exc:
                out[method] = {"failed": f"{type(exc).__name__}: {exc}"[:120], "time": time.perf_counter() - t0}
    dc_true = exp.truth.dc_gain
    if case == "realistic":
        # dead-zone and Coulomb friction cost a fixed part of the step: the gain a step
        # response can show is the linear gain times (1 - offset/step)
        dc_true *= 1.0 - exp.truth.equivalent_input_offset_v / exp.step_volts
    # the bound of this run's captures (their lengths and pre-step parts differ run to run)
    bound = crlb(name, cond_fine, sigma) if case == "white" else None
    tau_true = residence_tau(exp.truth.velocity)  # realistic: main() takes the effective one
    return name, case, seed, dc_true, tau_true, out, bound


def residence_tau(tf) -> float:
    """Mean residence time by moments (``Σ1/p − Σ1/z``) of every pole and zero of the truth."""
    num = np.atleast_1d(np.squeeze(tf.num[0][0])).astype(float)
    den = np.atleast_1d(np.squeeze(tf.den[0][0])).astype(float)
    return first_order_of(num, den)[1]


def crlb(name: str, cond, sigma: float) -> tuple[float, float]:
    """Cramér–Rao bound of DC gain and τ for the white case, for one run's captures.

    The experiment as the estimator sees it: every sample of each capture after its step
    (each capture's own grid and length) and its pre-step samples, every channel's pre-step
    level and each capture's sub-sample timing unknown (nuisance parameters), white noise
    ``sigma``, the step level read off each capture's noisy input channel; the true model in the
    output-error parameterisation (gain, time constants, zeros, position scale, current numerator,
    offsets, shifts).  Poles faster than half a
    sample are left out (no estimator can see them: they act as a lag the capture shifts
    take up, see :func:`visible_tau`); the current then jumps at the step: its numerator
    gets a direct term (the reduced model ``(Js + b)/(R(Js + b) + K²)`` of a negligible
    inductance), and, as in the estimator, no shift and no sample at the jump.
    """
    from motorid.identification.output_error import OeSettings, _Layout, _predict
    from motorid.trainer import truth_of

    tr = truth_of(replace(preset(name).ideal(), noise_v=sigma))
    dt = min(r.sample_interval_s for r in cond.responses.values())

    def poly(tf):
        return (np.atleast_1d(np.squeeze(tf.num[0][0])).astype(float),
                np.atleast_1d(np.squeeze(tf.den[0][0])).astype(float))

    vnum, vden = poly(tr.velocity)
    taus = sorted((-1.0 / np.real(np.roots(vden))).tolist(), reverse=True)
    zs = [-1.0 / np.real(z) for z in np.roots(vnum)] if vnum.size > 1 else []
    fast = [x for x in taus if x < dt / 2]
    taus = [x for x in taus if x >= dt / 2]
    k = float(vnum[-1] / vden[-1])
    pnum, pden = poly(tr.position)
    c = float(pnum[-1] / pden[-2]) / k
    channels = [ch for ch in ("velocity", "position", "current") if ch in cond.responses]
    # shifts on, as the estimator; a direct current term only where the reduced truth has one
    settings = OeSettings(n_poles=len(taus), n_zeros=len(zs), current_direct=bool(fast))
    layout = _Layout(settings, channels)
    theta = [k, *list(np.log(taus)), *list(zs), c]
    if "current" in channels:
        cnum, cden = poly(tr.current)
        # I(s) = cnum/cden over Π(1 + τ_i s) (cden monic, cden(0) = Π p_i): numerator
        # cnum/cden(0); with a fast pole 1/(1 + τ_f s) dropped the same numerator is biproper
        cur = cnum / cden[-1]
        cur = np.r_[np.zeros(layout.n_current - cur.size), cur]
        theta += list(cur)
    theta += [0.0] * len(channels)  # offsets
    theta += [0.0] * len(layout.shifted)  # time shifts of the separately triggered captures
    n_model = len(theta)
    # the step level is measured too: each capture's CH1 holds it (with its own baseline) in
    # the same white noise; the level and the input baselines are nuisance parameters
    theta += [cond.step_volts] + [0.0] * len(channels)
    theta = np.asarray(theta, dtype=float)
    grids = {ch: cond.responses[ch].time_s[cond.responses[ch].time_s >= 0] for ch in channels}
    if "current" in grids:  # as the estimator: the sample at the edge is left out
        grids["current"] = grids["current"][1:]
    n_pre = {ch: int(np.sum(cond.responses[ch].time_s < 0)) for ch in channels}

    def pred(th):
        step, u_base = th[n_model], th[n_model + 1 :]
        out = _predict(layout, th[:n_model], grids, step, channels)
        q = layout.unpack(th[:n_model])
        parts = [out[ch] for ch in channels] + [np.full(n_pre[ch], q["off"][ch]) for ch in channels]
        for i, ch in enumerate(channels):
            parts += [np.full(n_pre[ch], u_base[i]), np.full(grids[ch].size, u_base[i] + step)]
        return np.concatenate(parts)

    h = 1e-6 * np.maximum(np.abs(theta), 1e-3)
    h[n_model - len(layout.shifted) : n_model] = 1e-7  # shifts are seconds around 0
    jac = np.column_stack([(pred(theta + e) - pred(theta - e)) / (2 * hh)
                           for e, hh in zip(np.diag(h), h, strict=True)])
    cov = np.linalg.pinv(jac.T @ jac) * sigma**2
    n = len(taus)
    g_dc = np.zeros_like(theta)
    g_dc[0] = 1.0
    g_tau = np.zeros_like(theta)
    g_tau[1 : 1 + n] = np.exp(theta[1 : 1 + n])  # d τ_i / d log τ_i
    g_tau[1 + n : 1 + n + len(zs)] = -1.0
    return float(np.sqrt(g_dc @ cov @ g_dc)), float(np.sqrt(g_tau @ cov @ g_tau))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--presets", default="first-order,second-order,third-order")
    ap.add_argument("--cases", default="white,realistic")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--sigma", type=float, default=0.02, help="white-case noise, V rms")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--scheduler", default=None, help="Dask scheduler address: run on its workers instead")
    args = ap.parse_args()
    methods = tuple(m for m in args.methods.split(",") if m)
    if "peer:n4sid" in methods:
        try:
            import sippy_unipi  # noqa: F401
        except Exception as exc:
            print(f"peer:n4sid skipped: sippy-unipi does not import ({exc})")
            methods = tuple(m for m in methods if m != "peer:n4sid")
    cases = {p: ["realistic"] if p in REAL_SETUP_PRESETS else args.cases.split(",") for p in args.presets.split(",")}
    jobs = [(p, c, s, args.sigma, methods) for p in args.presets.split(",") for c in cases[p]
            for s in range(args.runs)]
    t_start = time.perf_counter()
    from rich.console import Console
    from rich.progress import track

    from motorid.batch import parallel_map

    runs = parallel_map(one_run, [(str(i), job) for i, job in enumerate(jobs)], jobs=args.jobs,
                        scheduler=args.scheduler, ordered=True, batch_size="auto")
    results = [r for _, r in track(runs, total=len(jobs), description="Monte-Carlo runs",
                                   console=Console(stderr=True))]
    where = f"Dask scheduler {args.scheduler}" if args.scheduler else f"{args.jobs} processes"
    print(f"{len(jobs)} runs in {time.perf_counter() - t_start:.0f} s ({where})")
    for p in args.presets.split(","):
        for c in cases[p]:
            rows = [r for r in results if r[0] == p and r[1] == c]
            dc_true, tau_true = rows[0][3], rows[0][4]
            tau_linear = None
            if c == "realistic" and p not in REAL_SETUP_PRESETS:
                tau_linear = tau_true
                # what the step can show, as the DC gain: the residence time of the noise-free step
                # with friction and dead-zone (sliding friction lengthens it by about La/Ra × the
                # part of the step it costs: 2.6 ms on the underdamped motor, ≤ 0.35 ms elsewhere)
                tau_true = step_residence_time(preset(p), STEP_VOLTS)
            # RMSE is compared with the root mean CRLB variance over the runs
            bound = (tuple(float(np.sqrt(np.mean([r[6][i] ** 2 for r in rows]))) for i in (0, 1))
                     if c == "white" else None)
            what = "effective (linear × (1 − offset/step))" if c == "realistic" else "linear"
            if p in REAL_SETUP_PRESETS:
                what, c_label = "incremental, as the step shows it", "files as the set-up writes them"
            else:
                c_label = f"{c} noise"
            tau_label = ("τ + dead time" if p in REAL_SETUP_PRESETS
                         else "residence time of the noise-free step (friction and dead-zone; estimates: τ + dead time)"
                         if c == "realistic" else "τ by moments (all poles; estimates: τ + dead time)")
            head = f"\n{p}, {c_label}: truth dc gain {dc_true:.4g} ({what}), {tau_label} {tau_true:.4g} s"
            if bound:
                head += f"; CRLB std dc {bound[0]:.2e}, τ {bound[1]:.2e}"
            print(head)
            print(f"{'method':<16}{'dc bias':>9}{'dc RMSE':>9}{'/CRLB':>7}{'τ bias':>9}{'τ RMSE':>9}{'/CRLB':>7}"
                  f"{'order ok':>9}{'cover95':>10}{'fail':>6}{'median ms':>10}")
            linear_bias: list[str] = []
            for m in methods:
                if p in REAL_SETUP_PRESETS and m not in REAL_SETUP_METHODS:
                    continue
                ok = [r[5][m] for r in rows if r[5].get(m) and not r[5][m].get("failed")]
                fails = sum(1 for r in rows if r[5].get(m, {}).get("failed"))
                if not ok:
                    reason = next((r[5][m]["failed"] for r in rows if r[5].get(m, {}).get("failed")), "")
                    print(f"{m:<16} all {fails} runs failed: {reason}")
                    continue
                dc = np.array([o["dc"] for o in ok]) - dc_true
                tau = np.array([o["tau"] for o in ok]) - tau_true
                rm_dc, rm_tau = float(np.sqrt(np.mean(dc**2))), float(np.sqrt(np.mean(tau**2)))
                r_dc = f"{rm_dc / bound[0]:7.2f}" if bound else f"{'—':>7}"
                r_tau = f"{rm_tau / bound[1]:7.2f}" if bound else f"{'—':>7}"
                # the real set-ups' "order" depends on what the sampling resolves: not scored
                order_ok = np.mean([o["order"] == TRUE_ORDER[p] for o in ok]) if p in TRUE_ORDER else np.nan
                cis = [o for o in ok if o["ci"]]
                cover = (f"{np.mean([(o['ci'][0][0] <= dc_true <= o['ci'][0][1]) for o in cis]):.2f}/"
                         f"{np.mean([(o['ci'][1][0] <= tau_true <= o['ci'][1][1]) for o in cis]):.2f}") if cis else "—"
                med = 1000 * statistics.median(o["time"] for o in ok)
                def num(x: float) -> str:
                    return f"{x:9.4f}" if 1e-3 <= abs(x) < 1e4 or x == 0 else f"{x:9.1e}"

                r_dc = r_dc if len(r_dc.strip()) <= 7 else f"{rm_dc / bound[0]:7.1e}"
                r_tau = r_tau if len(r_tau.strip()) <= 7 else f"{rm_tau / bound[1]:7.1e}"
                print(f"{m:<16}{num(dc.mean())}{num(rm_dc)}{r_dc}{num(tau.mean())}{num(rm_tau)}{r_tau}"
                      f"{'—' if np.isnan(order_ok) else f'{order_ok:.2f}':>9}{cover:>10}{fails:6d}{med:10.1f}")
                if tau_linear is not None:
                    linear_bias.append(f"{m} {tau.mean() + tau_true - tau_linear:+.1e}")
            if tau_linear is not None and linear_bias:
                # the current sees sliding friction as a constant torque its free numerator takes
                # up: a fit with the current capture leans to the motor's linear time constant
                print(f"τ bias against the linear motor's τ by moments ({tau_linear:.4g} s): " + ", ".join(linear_bias))


if __name__ == "__main__":
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):  # tiny matrices: one BLAS thread per process is fastest
        main()
