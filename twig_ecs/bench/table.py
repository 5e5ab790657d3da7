"""The ``twig bench`` report as text tables."""

from __future__ import annotations


def _ms(value: float | None) -> str:
    return "-" if value is None else f"{value:.3f}"


def _s(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def format_report(report: dict) -> str:
    """Two tables: step times with the MuJoCo comparison, then the split by system."""
    s = report["startup"]
    how = "compiled now" if s["compiled"] else "from the cache"
    lines = [f"kernels ready in {s['seconds']:.2f} s ({how}); {report['steps']} timed steps per case after "
             f"{report['warmup']}, medians (ms per 1/60 s step)", ""]  # fmt: skip
    head = (f"{'case':<15}{'bodies':>7}{'nodes':>7}{'median':>9}{'p95':>9}{'us/body':>9}{'mujoco':>9}"
            f"{'ours/mj':>9}")  # fmt: skip
    lines += [head, "-" * len(head)]
    for r in report["cases"]:
        m = r.get("mujoco")
        per = f"{1000.0 * r['median_ms'] / r['bodies']:.1f}"
        ratio = f"{r['vs_mujoco']:.2f}" if "vs_mujoco" in r else "-"
        lines.append(f"{r['case']:<15}{r['bodies']:>7}{r['nodes']:>7}{r['median_ms']:>9.3f}"
                     f"{r['p95_ms']:>9.3f}{per:>9}{_ms(m and m['median_ms']):>9}{ratio:>9}")  # fmt: skip
    versions = {r["mujoco"]["version"] for r in report["cases"] if "mujoco" in r}
    if versions:
        lines.append(f"mujoco {versions.pop()}: as many capsule humanoid ragdolls (13 capsules), dt 1/60, "
                     "default solver, stepped in turn with ours; ours/mj < 1: we are faster")  # fmt: skip
    lines.append("")
    lines.append("set-up (s): building the scene, its first step (installing its systems), MuJoCo's model "
                 "(compiled, or loaded from the cache)")  # fmt: skip
    for r in report["cases"]:
        first = r.get("first_step_s")
        m = r.get("mujoco")
        mj = "-" if m is None else f"{m['build_s']:.2f}" + (" (cached)" if m.get("cached") else "")
        lines.append(f"{r['case']:<15} build {r['build_s']:>7.2f}  first step {_s(first):>6}  mujoco {mj}")
    lines.append("")
    lines.append("split by system (median ms; groups are medians of each step's sum; systems under 0.02 ms "
                 "in every case left out)")  # fmt: skip
    names: list[str] = []
    for r in report["cases"]:
        for n in r["systems_ms"]:
            if n not in names:
                names.append(n)
    shown = [n for n in names if any(r["systems_ms"].get(n, 0.0) >= 0.02 for r in report["cases"])]
    head = f"{'case':<15}{'physics':>9}{'behav.':>9}{'control':>9}  " + "  ".join(shown)
    lines += [head, "-" * min(len(head), 140)]
    for r in report["cases"]:
        g = r["groups_ms"]
        parts = "  ".join(f"{r['systems_ms'].get(n, 0.0):>{len(n)}.3f}" for n in shown)
        lines.append(
            f"{r['case']:<15}{g['physics']:>9.3f}{g['behaviour']:>9.3f}{g['control']:>9.3f}  {parts}"
        )
    return "\n".join(lines)
