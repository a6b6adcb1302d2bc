"""The feedback page of one student: every check with its points and message, and for a run check that
failed on a scene the student may see, a plot of their trajectory against the reference.

A page never shows hidden data: hidden checks' messages carry no numbers (``checks``) and get no plot.
"""

from __future__ import annotations

import base64
import html
import io

from mbdkit.checks import Outcome

STYLE = """
body { font-family: system-ui, sans-serif; max-width: 60rem; margin: 2rem auto; color: #222; }
h1 { font-size: 1.5rem; } .score { font-size: 1.2rem; }
table { border-collapse: collapse; width: 100%; } td, th { border-bottom: 1px solid #ddd; padding: .4rem; }
th { text-align: left; } td.points { white-space: nowrap; text-align: right; }
tr.passed td.status { color: #176d24; } tr.failed td.status { color: #a11; font-weight: bold; }
td.message { font-family: ui-monospace, monospace; font-size: .85rem; white-space: pre-wrap; }
figure { margin: 1rem 0; } figcaption { font-size: .9rem; color: #555; }
"""


def plot_png(plot: dict) -> str:
    """A PNG (base64) of the student's curve against the reference."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.2), dpi=90)
    ax.plot(plot["t"], plot["expected"], label="reference", linewidth=2.0)
    ax.plot(plot["t"], plot["got"], "--", label="your code", linewidth=1.5)
    ax.set_xlabel("t [s]")
    ax.set_ylabel(plot["label"])
    ax.set_title(plot["quantity"], fontsize=9)
    ax.legend()
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    plt.close(fig)
    return base64.b64encode(buffer.getvalue()).decode("ascii")


def feedback_html(student: str, homework: str, title: str, outcomes: list[Outcome]) -> str:
    """The whole page as a string."""
    score = sum(o.points for o in outcomes)
    total = sum(o.max_points for o in outcomes)
    rows, figures = [], []
    for o in outcomes:
        status = "passed" if o.passed else "failed"
        rows.append(
            f'<tr class="{status}"><td>{html.escape(o.name)}</td><td class="status">{status}</td>'
            f'<td class="points">{o.points:g} / {o.max_points:g}</td>'
            f'<td class="message">{html.escape("" if o.passed else o.message)}</td></tr>'
        )
        if not o.passed and o.plot is not None and o.kind != "hidden":
            figures.append(
                f'<figure><img alt="{html.escape(o.name)}" src="data:image/png;base64,{plot_png(o.plot)}">'
                f"<figcaption>{html.escape(o.name)}: {html.escape(o.plot['label'])}, your run against the "
                "reference</figcaption></figure>"
            )
    plots = "<h2>Where your runs leave the reference</h2>" + "".join(figures) if figures else ""
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(homework)}: {html.escape(student)}</title>
<style>{STYLE}</style></head><body>
<h1>{html.escape(homework)} {html.escape(title)}: feedback for {html.escape(student)}</h1>
<p class="score">Score: <b>{score:g} / {total:g}</b></p>
<table><tr><th>check</th><th>status</th><th>points</th><th>message</th></tr>
{"".join(rows)}
</table>
{plots}
</body></html>
"""
