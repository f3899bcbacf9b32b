"""Is a terrain rigid?  The evidence a robot's own logs hold of deformable ground.

A rigid-floor tire law (Ch. 4) has a robot's wheels roll on a surface that does not
give.  Ground that does (sand, loam, snow) shows in three ways the logs record, each
measured here and named in the verdict:

- **rolling resistance**: driving straight on a hard floor the motors only overcome
  the drivetrain's and the tyres' own losses; on ground that sinks they also compact
  and bulldoze it (Bekker's compaction resistance), so the straight-driving motor
  current rises.  The ratio to the robot's current on rigid terrains (those of the
  same diagnosis, or the value the identified robot carries) is the evidence;
- **stuck segments**: turning commands under which the robot hardly turns (chi above
  identify.stuck_chi: wheels spinning in a rut, or a drive that stalls);
- **scatter**: a terrain whose turning segments' chi, the stuck ones aside, scatters
  beyond one behaviour (its robust standard error above MAX_RELATIVE_SCATTER of the
  median).

A terrain is called deformable when its rolling current reaches ROLLING_RATIO times
the rigid reference; without a current to compare (none logged, or no rigid
reference), when both other signs show.  Stuck turns and scatter also happen on hard
ground (a drive too weak to break away on a grippy floor, wheels spinning on ice), so
where the rolling current says rigid, they do not overrule it.
"""

from __future__ import annotations

import numpy as np

from skidsteer.diagnosis import identify

# A hard floor's straight-driving current moves by about 15 % with speed and floor
# (BorealTC's Husky: 1.90 A on flooring at 0.23 m/s, 2.17 A on asphalt at 0.47 m/s);
# 1.5x the rigid reference is clear of it.  Set before judging any terrain.
ROLLING_RATIO = 1.5
STUCK_SHARE = 0.2  # a fifth of the turning segments stuck is a sign
MAX_RELATIVE_SCATTER = 0.1


def rolling_current(rows: list[dict]) -> float | None:
    """The median of the straight segments' mean motor current (A, both sides), None
    without currents."""
    values = [r["current_a"] for r in rows if r["kind"] == "straight"
              and r.get("current_a") is not None]
    return float(np.median(values)) if values else None


def signs(rows: list[dict], stuck_chi: float) -> dict:
    """The stuck share and chi scatter of a terrain's turning segments."""
    turning = [r for kind in identify.TURN_KINDS for r in identify.turning(rows, kind)]
    stuck = [r for r in rows if r["kind"] in identify.TURN_KINDS
             and r["yaw_rate_predicted_deg_s"] is not None
             and abs(r["yaw_rate_predicted_deg_s"]) >= identify.MIN_TURN_DEG_S
             and (r["chi_measured"] is None or r["chi_measured"] >= stuck_chi)]
    n = len(turning) + len([r for r in stuck if r["chi_measured"] is None])
    scatter = {}
    for kind in identify.TURN_KINDS:
        s = identify.median_summary([r["chi_measured"] for r in
                                     identify.turning(rows, kind, None, stuck_chi)])
        if s["n"] >= 5 and s["value"]:
            scatter[kind] = s["stderr"] / abs(s["value"])
    return {"turning_segments": n, "stuck_segments": len(stuck),
            "stuck_share": len(stuck) / n if n else 0.0, "relative_scatter": scatter}


def judge(rows: list[dict], stuck_chi: float, rigid_current: float | None) -> dict:
    """The evidence and whether it says deformable (see the module's rule)."""
    found = signs(rows, stuck_chi)
    current = rolling_current(rows)
    found["rolling_current_a"] = current
    found["rigid_rolling_current_a"] = rigid_current
    ratio = current / rigid_current if current and rigid_current else None
    found["rolling_current_ratio"] = ratio
    evidence = []
    if ratio is not None and ratio >= ROLLING_RATIO:
        evidence.append(f"driving straight takes {ratio:.1f}x the motor current it takes on "
                        f"rigid ground ({current:.2f} A against {rigid_current:.2f} A): "
                        "rolling resistance of ground that sinks")
    other = []
    if found["stuck_share"] >= STUCK_SHARE:
        other.append(f"{found['stuck_segments']} of {found['turning_segments']} turning "
                     "segments barely turn (stuck)")
    scattered = [k for k, v in found["relative_scatter"].items() if v > MAX_RELATIVE_SCATTER]
    if scattered:
        other.append("chi scatters beyond one behaviour (" + ", ".join(
            f"{k}: {found['relative_scatter'][k]:.0%} of the median" for k in scattered) + ")")
    deformable = bool(evidence) if ratio is not None else len(other) >= 2
    found["deformable"] = deformable
    found["evidence"] = evidence + other
    if not deformable and ratio is None:
        found["evidence"].append(
            "taken as rigid for want of evidence: no straight-driving current here"
            if current is None else "taken as rigid for want of evidence: no rigid terrain's "
            "straight-driving current to compare this one's with")
    return found
