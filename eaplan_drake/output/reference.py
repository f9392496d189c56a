"""The paper's reference numbers (paper 003 Sec. V and the authors' logs) and the table that
sets a flight's summary beside them (``eaplan-drake compare``, notebook 03)."""

__all__ = ["PAPER_RESULTS", "CompareTable"]

PAPER_RESULTS = {
    # paper 003 Sec. V / the authors' logs: survey time [s] and metric P (None = fails)
    "plan_I": {"duration": 724.7, "metric": None},
    "plan_II": {"duration": 318.7, "metric": 0.0},
    "plan_i": {"duration": 403.2, "metric": 13.045},
    "plan_ii": {"duration": 662.0, "metric": 2.245},
}


def CompareTable(rows) -> str:
    """A Markdown table of (name, our summary, paper numbers) rows: quality and completion
    first, the paper's metric P last."""

    def fmt(m):
        return "fail" if m is None else f"{m:.3f}"

    lines = [
        "| flight | policy | status | quality | final margin | time [s] | paper time [s] | P | "
        "paper P |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for name, s, paper in rows:
        lines.append(
            f"| {name} | {s.get('policy', '')} | {s['status']} | {s['quality']:.3f} | "
            f"{s['final_margin']:+.3f} | {s['duration']:.1f} | {paper['duration']:.1f} | "
            f"{fmt(s['metric'])} | {fmt(paper['metric'])} |"
        )
    return "\n".join(lines)
