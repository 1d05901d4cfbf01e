"""The rows of docs/benchmarks.md's generated table (bench/report.py): for each, the results file under
bench/results/, the key in it, what it means and the target it is held to.
"""

from __future__ import annotations

# (results file, key, what it means, target)
HEADLINE = [
    ("sim", "realtime_factor", "simulated s per wall s, two-rig 10 s scene, default settings", "≥ 200"),
    ("sim", "max_error_C", "max error vs refined reference, °C", "≤ 0.05"),
    ("sim", "speedup_vs_solve_ivp", "speed-up vs scipy solve_ivp (BDF) at equal error", "≥ 10"),
    ("sim", "pruning_speedup", "speed-up from scene pruning", "> 1"),
    (
        "identify",
        "worst_free_run_error_C",
        "worst free-run error, order 3, held-out PRBS, °C",
        "≤ 0.3 (aim 0.1)",
    ),
    ("identify", "flux_error_W", "heat-flux model error, W", "~0.0025"),
    ("identify", "fit_ms_order3_10k", "batch fit, order 3, 10,000 samples, ms", "≤ 50"),
    ("identify", "rls_us_per_update", "RLS update, µs", "≤ 30"),
    (
        "transparency",
        "headline_error_C",
        "skin vs direct touch, mean over t_on − 0.5 s .. t_on + 1 s, °C",
        "≤ 1.25 × bound",
    ),
    (
        "transparency",
        "bound_headline_error_C",
        "the same for optimal currents (finger matched, no foreknowledge), °C",
        "physics",
    ),
    (
        "transparency",
        "pre_contact_mean_error_C",
        "skin vs direct touch, 0.5 s before each touch, °C",
        "≤ 0.3",
    ),
    (
        "transparency",
        "paper_law_headline_error_C",
        "headline of the paper's law as published, °C",
        "baseline",
    ),
    (
        "transparency",
        "null_display_min_ratio_to_project",
        "best null display's headline / the project's",
        "≥ 3",
    ),
    (
        "transparency",
        "drift_10min_C",
        "both pads in air 10 min after a scene, largest deviation from neutral, °C",
        "≤ 1",
    ),
    (
        "control",
        "transparency_early_mean_error_C",
        "(earlier figure) contact T vs direct touch, 0.1–1 s, °C",
        "—",
    ),
    ("control", "tracking_rms_C", "tracking RMS in steady contact (internal: vs own estimate), °C", "—"),
    (
        "nodes",
        "lockstep_cycles_per_s_virtual",
        "two-node lockstep, in-process virtual bus, cycles/s",
        "≥ 2000",
    ),
    ("nodes", "lockstep_cycles_per_s_hub", "two processes over the socketcand hub, cycles/s", "≥ 1000"),
    (
        "nodes_lockstep",
        "lockstep_ratio_vs_raw_virtual",
        "lockstep cycles/s over a raw python-can ping-pong, same run, virtual bus",
        "≥ 0.75",
    ),
    ("nodes_lockstep", "lockstep_ratio_vs_raw_hub", "the same over the hub (two processes)", "≥ 0.75"),
    (
        "nodes_lockstep",
        "lockstep_cpu_ratio_vs_raw_virtual",
        "the virtual ratio in CPU time of the process (anchor CPU/cycle over lockstep CPU/cycle; "
        "less load-sensitive than wall time)",
        "≥ 0.75",
    ),
    (
        "nodes",
        "lockstep_cycles_per_s_vcan",
        "two processes over vcan0 (in the VM), cycles/s",
        "≥ 1000 natively",
    ),
    ("nodes", "late_cycles_100hz_60s", "late cycles, real time 100 Hz, 60 s", "0"),
    ("nodes", "late_fraction_1khz", "late fraction, real time 1 kHz", "report"),
    (
        "identify_live",
        "live_heldout_free_run_max_C",
        "`telethermo identify master` on a live node (hub, lockstep), held-out worst, °C",
        "= offline",
    ),
    (
        "identify_live",
        "live_wall_s",
        "the same command end to end (set-up, experiment, fit, load + CRC), s",
        "report",
    ),
    (
        "cli",
        "help_ratio_vs_can_viewer",
        "`telethermo --help` / `python -m can.viewer --help`, medians, one run",
        "≤ 1.5",
    ),
    (
        "cli",
        "get_ratio_vs_raw_canopen",
        "one `telethermo get master kp_A_per_C` (live node, hub) / a minimal canopen "
        "script's SDO read, medians, one run",
        "≤ 1.5",
    ),
    (
        "rendering",
        "material_id_accuracy",
        "slave material identification, 600 simulated touches (10 materials, "
        "2-10 N, 15-35 °C, 1-20 mm), calibrated classifier (reference touches of other seeds)",
        "≥ 0.95",
    ),
    (
        "rendering",
        "material_id_accuracy_physics",
        "the same touches: the physics estimator alone (nearest table effusivity), same run",
        "report",
    ),
    (
        "rendering",
        "material_id_accuracy_heldout",
        "calibrated classifier on 600 held-out touches (other seeds, same distribution)",
        "report",
    ),
    (
        "rendering",
        "material_id_accuracy_bound",
        "the same touches: oracle that knows the simulator, object temperature, "
        "contact resistance, thickness unknown (physical ceiling)",
        "report",
    ),
    (
        "rendering",
        "material_id_accuracy_merged",
        "accuracy with the pairs the probe confuses merged (second figure)",
        "report",
    ),
    (
        "material_id",
        "material_id_envelope_accuracy_late",
        "refined answer (1.31 s), 2739 touches across the envelope, outside the 2 °C band (abstain = wrong)",
        "≥ 0.98",
    ),
    (
        "material_id",
        "material_id_envelope_oracle_late",
        "the same touches (every 4th): local oracle over the refined answer's 1.2 s (knows the simulator)",
        "report",
    ),
    (
        "material_id",
        "material_id_envelope_accuracy_early",
        "early answer (0.49 s), the same touches (abstain = wrong)",
        "≥ 0.90",
    ),
    (
        "material_id",
        "material_id_envelope_oracle_early",
        "the same touches: local oracle over the early answer's 0.42 s",
        "report",
    ),
    (
        "material_id",
        "material_id_envelope_accuracy_late_merged",
        "refined answer with the pairs its oracle confuses ≥ 20 % merged (second figure)",
        "report",
    ),
    (
        "material_oracle_profiled",
        "material_oracle_profiled_late",
        "134 of those touches, the slave's own records: each candidate's force, thickness, object fitted "
        "(not linearised) on the simulator, onset free; refined window",
        "report",
    ),
    (
        "material_oracle_profiled",
        "material_oracle_profiled_gap_late",
        "the slave's refined answer's paired gap to it, same records (its SE in the results file)",
        "report",
    ),
    (
        "material_oracle_profiled",
        "material_oracle_laplace_late",
        "the same fits weighed by Laplace's evidence (near the posterior marginalised over the nuisances)",
        "report",
    ),
    (
        "material_oracle_profiled",
        "material_oracle_linearised_record_late",
        "the same records: one linear projection from the touch's nuisances (the local oracle's form)",
        "report",
    ),
    (
        "material_early_abstention",
        "early_accuracy_shipped",
        "early answer on 2000 development touches of the envelope (the slave as shipped; abstains wrong)",
        "report",
    ),
    (
        "material_early_abstention",
        "early_accuracy_name_no_fit",
        "the same touches with the early `no_fit` abstentions named by the classifier (not shipped)",
        "report",
    ),
    (
        "material_early_abstention",
        "outside_confident_precision_early_shipped",
        "400 touches beyond the envelope: early answers at posterior ≥ 0.9 that are right, as shipped",
        "report",
    ),
    (
        "material_early_abstention",
        "outside_confident_precision_early_name_no_fit",
        "the same with `no_fit` named: what naming them costs beyond the envelope",
        "report",
    ),
    (
        "monitor",
        "decode_frames_per_s",
        "`Monitor.feed` on a 1 ms-cycle mix of the pair (EDS-decoded), frames/s",
        "≥ 8000",
    ),
    (
        "monitor",
        "ratio_vs_anchor",
        "that rate / python-can's raw `recv()` rate of the same frames, same run",
        "report",
    ),
    ("monitor", "live_frames_per_s", "`recv()` + `feed()` per frame, virtual bus, frames/s", "≥ 8000"),
    (
        "monitor",
        "hub_live_frames_per_s",
        "the same live over a hub process, fed by a sender process, frames/s (0 frames lost)",
        "≥ 8000",
    ),
    (
        "monitor",
        "hub_live_ratio_vs_anchor",
        "that rate / python-can's socketcand `recv()` over the same hub, same run",
        "report",
    ),
    (
        "realtime",
        "peer_lost_trips_10min_loaded",
        "peer-lost trips, 10 min at 100 Hz real time over the hub, 2 busy "
        "processes and `telethermo status` every 3 s, nodes with `--rt-priority 50 --gc freeze`",
        "0",
    ),
    ("realtime", "late_fraction", "late cycles / cycles in that run", "report"),
    ("realtime", "latency_p99_ms", "SYNC -> master TPDO1 latency p99 in that run, ms", "report"),
    (
        "realtime_no_rt",
        "peer_lost_trips_10min_loaded",
        "the same run without the real-time options (`--no-rt`): peer-lost trips",
        "baseline",
    ),
    ("realtime_no_rt", "late_fraction", "without the options: late cycles / cycles", "baseline"),
    ("realtime_no_rt", "latency_p99_ms", "without the options: SYNC -> TPDO1 latency p99, ms", "baseline"),
    (
        "conformance",
        "n_fail",
        "CiA 301 checks failed through an independent client (of n_checks), live pair",
        "0",
    ),
    (
        "envelope",
        "envelope_n_conditions",
        "operating envelope: conditions scored (Latin hypercube + corners), each a "
        "full §5.3 session with gains from its own identified rigs",
        "≥ 200",
    ),
    (
        "envelope",
        "envelope_oscillating_conditions",
        "conditions whose skin oscillates in settled contact (> 1.5× the "
        "direct touch's 0.3–5 Hz RMS, floor 0.05 °C, with the current swinging)",
        "0",
    ),
    ("envelope", "envelope_session_long_cuts", "conditions with a current cut of ≥ 5 s", "0"),
    ("envelope", "envelope_unexpected_trips", "conditions with any trip", "0"),
    (
        "envelope",
        "envelope_beats_best_pad_fraction",
        "share of conditions whose headline beats the best constant pad "
        "(ambient, objects' or neutral temperature, clamped)",
        "≥ 0.9",
    ),
    (
        "envelope",
        "envelope_median_ratio_to_bound",
        "headline / optimal-current bound, median over the bound subset",
        "≤ 1.25",
    ),
    (
        "envelope",
        "envelope_captured_fraction_median",
        "(pad − ours) / (pad − bound), median over the bound subset",
        "≥ 0.7",
    ),
    (
        "envelope_bound_all",
        "safe_bound_beats_best_pad_fraction",
        "the physics' share: max(optimal-current bound, clamped ideal display) beats the best pad, all 216 "
        "conditions (the ceiling of the share above for a display that keeps the finger natural until a "
        "touch)",
        "≥ 0.9 for the target to be reachable",
    ),
    (
        "envelope_bound_all",
        "median_ratio_to_bound",
        "headline / optimal-current bound, median over all 216 conditions (the subset's beside it: "
        "`subset_median_ratio_to_bound`)",
        "≤ 1.25",
    ),
    (
        "envelope_bound_all",
        "captured_fraction_median_safe",
        "(pad − ours) / (pad − safe bound), median over the conditions the safe bound wins",
        "≥ 0.7",
    ),
    (
        "envelope_bound_clamped",
        "clamped_bound_beats_best_pad_fraction",
        "the physics' share with the skin kept inside the clamps at every sample: the clamped "
        "optimal-current bound beats the best pad, all 216 conditions (the ceiling of "
        "`envelope_beats_best_pad_fraction` for a display that keeps the finger natural until a touch "
        "and the skin inside [14.5, 43.5] °C)",
        "≥ 0.9 for the target to be reachable",
    ),
    (
        "envelope_bound_clamped",
        "median_ratio_to_clamped_bound",
        "headline / clamped bound, median over all 216 conditions",
        "≤ 1.25",
    ),
    (
        "envelope_bound_from_display",
        "from_display_beats_best_pad_fraction",
        "of the conditions the controller loses and the clamped bound wins, the share the clamped bound "
        "still wins from our display's own state 0.5 s before each touch (what control inside the window "
        "alone could win)",
        "—",
    ),
    (
        "envelope",
        "envelope_cue_order_kept_fraction",
        "material cue order kept, conditions whose direct cues differ ≥ 20 %",
        "≥ 0.95",
    ),
    (
        "envelope",
        "render_early_rms_worst_C",
        "render mode, early (0–1 s) skin RMS vs direct touch, worst touch whose "
        "eq. 1 contact lies in the clamps' band, °C",
        "≤ 0.5",
    ),
    (
        "envelope",
        "render_early_rms_worst_not_clamped_C",
        "the same, touches whose eq. 7 pre-set the skin clamp does not stop, with the simulated operator's "
        "own β (shipped table, same run: `render_early_rms_worst_not_clamped_shipped_table_C` 0.759)",
        "≤ 0.5",
    ),
    ("envelope", "workers_2_speedup", "the first conditions on 2 workers vs 1, same run", "≥ 1.7"),
    (
        "envelope",
        "envelope_skin_past_clamp_worst_C",
        "the operator's skin past its [15, 43] °C clamps, worst condition of the matrix, °C",
        "0",
    ),
    (
        "envelope",
        "envelope_clamp_reached_fraction",
        "where the direct touch's skin passes a clamp (`envelope_clamp_crossed_conditions`), the share whose "
        "skin comes within 0.5 °C of it (a pad held at that clamp, same run: "
        "`envelope_clamp_reached_fraction_pad`; short by `envelope_clamp_short_median_C` against "
        "`envelope_clamp_short_pad_median_C`)",
        "1",
    ),
    (
        "envelope_heldout",
        "envelope_session_long_cuts",
        "a held-out draw of the envelope (seed 30_2026, 100 conditions nothing was chosen on): long cuts",
        "0",
    ),
    ("envelope_heldout", "envelope_unexpected_trips", "the held-out draw: conditions with any trip", "0"),
    (
        "envelope_heldout",
        "envelope_skin_past_clamp_worst_C",
        "the held-out draw: the skin past its clamps, worst condition, °C",
        "0",
    ),
    ("envelope_heldout", "envelope_clamp_reached_fraction", "the held-out draw: the same share", "1"),
    ("envelope_heldout", "envelope_oscillating_conditions", "the held-out draw: oscillating conditions", "0"),
    (
        "envelope_heldout",
        "envelope_beats_best_pad_fraction",
        "the held-out draw: share beating the best constant pad",
        "≥ 0.9",
    ),
    (
        "envelope_probe_flux",
        "candidate_beats_best_pad_fraction",
        "experiment, not shipped: the matrix with the probe's flux loop (2 W deadband); beats the best pad",
        "shipped 0.495",
    ),
    (
        "envelope_probe_flux",
        "candidate_oscillating_conditions",
        "the same experiment: oscillating conditions (why it is not adopted: docs/control.md)",
        "shipped 25",
    ),
    (
        "envelope_virtual_finger",
        "candidate_beats_best_pad_fraction",
        "experiment, not shipped: a virtual finger on the probe (the base scene regresses: docs/control.md); "
        "beats the best pad",
        "shipped 0.495",
    ),
    (
        "envelope_virtual_finger",
        "candidate_oscillating_conditions",
        "the same experiment: oscillating conditions",
        "shipped 24",
    ),
    (
        "envelope_oscillation_rounds",
        "oscillation_rounds_flagged_touches_round_2",
        "the conditions envelope.json flags as oscillating, re-run: flagged touches in the schedule's second "
        "round (`_round_1`: 21; all 21 flags are first-round excursions)",
        "a limit cycle recurs",
    ),
    (
        "envelope_oscillation_rounds_shipped_gains",
        "oscillation_rounds_flagged_touches_round_2",
        "the control: the shipped gains on 15 conditions where they ring; flagged touches in round 2 (12 of "
        "15 conditions have one: `oscillation_rounds_round_2_flagged_conditions`)",
        "the count sees a cycle",
    ),
    (
        "material_lab",
        "material_lab_touches_needed",
        "lab calibration of the material physics fit: reference touches needed (a 0.7 mm sensor probe)",
        "a handful",
    ),
    (
        "material_lab",
        "material_lab_accuracy_after",
        "the same probe, physics posterior after the lab calibration (before: material_lab_accuracy_before)",
        "report",
    ),
    ("stress", "n_failed", "stress cases failed (of n_cases)", "0"),
    (
        "stress",
        "surface_rate_max_C_per_s",
        "master pad surface rate, peer trip to +5 s, worst case (simulated pair; "
        "contacts whose own transient stays under the bound), °C/s",
        "≤ 6 (ramp + 1)",
    ),
    (
        "stress",
        "surface_rate_max_before_C_per_s",
        "the same without the envelope's trip slew and lead bound, same run, °C/s",
        "baseline",
    ),
    (
        "stress",
        "surface_rate_max_immediate_cut_C_per_s",
        "the same after an immediate cut (NMT, sensor NaN, heat sink), °C/s",
        "physics (stored heat)",
    ),
]
