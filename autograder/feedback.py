"""The feedback page of one student: first the points per group of checks and each distinct cause of the failures
once (how many checks and points it costs, the largest first), then every check with its points and message (a
cause already listed is referred to by its number), and for a run check that failed on a scene the student may
see, a plot of their trajectory against the reference and of the difference.

A page never shows hidden data: hidden and per-student checks' messages are the grader's words only
(``mbdkit.withheld``) and get no plot. The hidden checks' results are held back until the instructor
publishes them (``mbd grade ... --publish-hidden``, ``publish``): until then the page says how many there are
and shows the score of the checks it lists.
"""

from __future__ import annotations

import base64
import html
import io

from mbdkit import notes
from mbdkit.checks import Outcome

STYLE = """
body { font-family: system-ui, sans-serif; max-width: 60rem; margin: 2rem auto; color: #222; }
h1 { font-size: 1.5rem; } .score { font-size: 1.2rem; }
table { border-collapse: collapse; width: 100%; } td, th { border-bottom: 1px solid #ddd; padding: .4rem; }
th { text-align: left; } td.points { white-space: nowrap; text-align: right; }
tr.passed td.status { color: #176d24; } tr.failed td.status { color: #a11; font-weight: bold; }
td.message, li.cause code { font-family: ui-monospace, monospace; font-size: .85rem; white-space: pre-wrap;
  overflow-wrap: anywhere; }
table.groups { width: auto; } ol.causes li { margin: .3rem 0; }
figure { margin: 1rem 0; } figcaption { font-size: .9rem; color: #555; }
"""


def plot_png(plot: dict) -> str:
    """A PNG (base64) of the student's curve against the reference."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, (ax, below) = plt.subplots(2, 1, figsize=(6.4, 4.4), dpi=90, sharex=True, height_ratios=(3, 2))
    ax.plot(plot["t"], plot["expected"], label="reference", linewidth=2.0)
    ax.plot(plot["t"], plot["got"], "--", label="your code", linewidth=1.5)
    ax.set_ylabel(plot["label"])
    ax.set_title(plot["quantity"], fontsize=9)
    ax.legend()
    below.plot(plot["t"], np.asarray(plot["got"], float) - np.asarray(plot["expected"], float), color="#a11")
    below.axhline(0.0, color="#888", linewidth=0.8)
    below.set_ylabel("yours - reference")  # curves that overlay still show their difference here
    below.set_xlabel("t [s]")
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    plt.close(fig)
    return base64.b64encode(buffer.getvalue()).decode("ascii")


HIDDEN_START, HIDDEN_END = "<!-- hidden checks -->", "<!-- /hidden checks -->"
SCORE_START, SCORE_END = "<!-- score -->", "<!-- /score -->"
"""Around the parts ``publish`` rewrites (a student's text in a page is escaped: it cannot forge them)."""


def _row(name: str, passed: bool, points: float, max_points: float, message: str, cause: int | None = None) -> str:
    """A check's row; ``cause``: the number of its cause in the list above, said instead of the message."""
    status = "passed" if passed else "failed"
    said = "" if passed else f"cause {cause} above" if cause is not None else message
    return (
        f'<tr class="{status}"><td>{html.escape(name)}</td><td class="status">{status}</td>'
        f'<td class="points">{points:g} / {max_points:g}</td>'
        f'<td class="message">{notes.html_links(html.escape(said))}</td></tr>'
    )


def cause_of(outcome: Outcome) -> str:
    """A failed check's message without the scene it names first ('four_bar: not implemented yet: ...'): the same
    mistake on several scenes is one cause."""
    prefix = f"{outcome.scene}: "
    return outcome.message[len(prefix) :] if outcome.message.startswith(prefix) else outcome.message


def causes(outcomes: list[Outcome], key=cause_of) -> list[tuple[str, list[Outcome]]]:
    """Each distinct cause of the failed checks (``key`` of a check: its cause) with the checks it fails, the
    most points lost first."""
    by_cause: dict[str, list[Outcome]] = {}
    for o in outcomes:
        if not o.passed:
            by_cause.setdefault(key(o), []).append(o)
    return sorted(by_cause.items(), key=lambda item: -sum(o.max_points - o.points for o in item[1]))


def summary_part(outcomes: list[Outcome]) -> str:
    """Points per group of the checks shown, then each cause of their failures once."""
    groups: dict[str, list[Outcome]] = {}
    for o in outcomes:
        groups.setdefault(o.group, []).append(o)
    rows = "".join(
        f'<tr><td>{html.escape(group)}</td><td class="points">{sum(o.points for o in done):g} / '
        f"{sum(o.max_points for o in done):g}</td><td>{sum(o.passed for o in done)} of {len(done)} passed</td></tr>"
        for group, done in groups.items()
    )
    parts = [f'<h2>By group</h2><table class="groups"><tr><th>group</th><th>points</th><th></th></tr>{rows}</table>']
    return "\n".join([*parts, causes_part(outcomes)]).rstrip("\n")


def causes_part(outcomes: list[Outcome], key=cause_of) -> str:
    """Each cause of the failures once (``key``: see ``causes``), with the checks and points it costs, the
    costliest first ("" if none failed); nbgrader's feedback page shows it first too (autograder/nbpages.py)."""
    items = []
    for cause, failed in causes(outcomes, key):
        lost, touched = sum(o.max_points - o.points for o in failed), ", ".join(dict.fromkeys(o.group for o in failed))
        count = f"{len(failed)} check{'s' if len(failed) > 1 else ''}"
        items.append(f'<li class="cause"><b>{count}, {lost:g} points</b> ({html.escape(touched)}): ')
        items[-1] += f"<code>{notes.html_links(html.escape(cause))}</code></li>"
    return f'<h2>What to fix, the costliest first</h2><ol class="causes">{"".join(items)}</ol>' if items else ""


def hidden_tests(tests: list[dict]) -> list[dict]:
    """The hidden checks among a result's Gradescope tests."""
    return [t for t in tests if t.get("extra_data", {}).get("kind") == "hidden"]


def score_part(tests: list[dict], published: bool) -> str:
    """The score line: the total once the hidden checks are published, else the checks shown and what is held."""
    score, total = sum(t["score"] for t in tests), sum(t["max_score"] for t in tests)
    hidden = hidden_tests(tests)
    if published or not hidden:
        return f'<p class="score">Score: <b>{score:g} / {total:g}</b></p>'
    shown = [t for t in tests if t not in hidden]
    held = sum(t["max_score"] for t in hidden)
    return (
        f'<p class="score">Score on the checks shown: <b>{sum(t["score"] for t in shown):g} / '
        f'{sum(t["max_score"] for t in shown):g}</b></p>\n<p class="held">{len(hidden)} more checks, on hidden '
        f"scenes ({held:g} points), were graded too: their results, and your total out of {total:g}, come when "
        "the instructor publishes them.</p>"
    )


def hidden_part(tests: list[dict], published: bool) -> str:
    """The hidden checks' rows once published (their messages are the grader's words only), else nothing."""
    if not published:
        return ""
    return "".join(_row(t["name"], t["status"] == "passed", t["score"], t["max_score"], t["output"]) for t in tests)


def feedback_html(
    student: str, homework: str, title: str, outcomes: list[Outcome], published: bool = False, documentation: str = ""
) -> str:
    """The whole page as a string; the hidden checks' results only when ``published`` (``publish`` adds
    them later to a page written without); ``documentation``: the rubric's part of the page (HTML, made by
    ``autograder.documentation``), after the summary."""
    tests = [o.to_test() for o in outcomes]
    shown = [o for o in outcomes if o.kind != "hidden"]
    numbered = {cause: k for k, (cause, _) in enumerate(causes(shown), start=1)}
    rows, figures = [], []
    for o in shown:
        rows.append(_row(o.name, o.passed, o.points, o.max_points, o.message, numbered.get(cause_of(o))))
        if not o.passed and o.plot is not None and o.kind == "public":
            figures.append(
                f'<figure><img alt="{html.escape(o.name)}" src="data:image/png;base64,{plot_png(o.plot)}">'
                f"<figcaption>{html.escape(o.name)}: {html.escape(o.plot['label'])}, your run against the "
                "reference, and the difference</figcaption></figure>"
            )
    plots = "<h2>Where your runs leave the reference</h2>" + "".join(figures) if figures else ""
    hidden = hidden_tests(tests)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(homework)}: {html.escape(student)}</title>
<style>{STYLE}</style></head><body>
<h1>{html.escape(homework)} {html.escape(title)}: feedback for {html.escape(student)}</h1>
<p class="notes">Each <i>eq. N.M</i> below opens the course notes of your homework kit (its <code>notes/</code>
folder): save this page in your homework's folder, beside <code>notes/</code>.</p>
{SCORE_START}{score_part(tests, published)}{SCORE_END}
{summary_part(shown)}
{documentation}
<h2>Every check</h2>
<table><tr><th>check</th><th>status</th><th>points</th><th>message</th></tr>
{"".join(rows)}
{HIDDEN_START}{hidden_part(hidden, published)}{HIDDEN_END}
</table>
{plots}
</body></html>
"""


def publish(page: str, result: dict) -> str | None:
    """A page written before publication with the hidden checks of its ``result`` (the results JSON) added
    and the total shown; a page already published comes back the same; None for a page not made here."""
    tests = result["tests"]
    if any(page.count(marker) != 1 for marker in (SCORE_START, SCORE_END, HIDDEN_START, HIDDEN_END)):
        return None
    for start, end, part in (
        (SCORE_START, SCORE_END, score_part(tests, True)),
        (HIDDEN_START, HIDDEN_END, hidden_part(hidden_tests(tests), True)),
    ):
        before, rest = page.split(start, 1)
        page = before + start + part + end + rest.split(end, 1)[1]
    return page
