"""Looking into a matplotlib Figure the way a reader does: its panels by row, its tick labels."""


def axes_by_row(fig):
    """Visible axes grouped by row (top to bottom), each row left to right."""
    rows = {}
    for ax in fig.axes:
        spec = ax.get_subplotspec()
        rows.setdefault(spec.rowspan.start, []).append((spec.colspan.start, ax))
    return [[ax for _, ax in sorted(rows[r], key=lambda x: x[0])] for r in sorted(rows)]


def check_no_offset(fig):
    """Draw `fig`; no axis prints its ticks with an offset ("1e-6+5.5e-1")."""
    fig.canvas.draw()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            fmt = axis.get_major_formatter()
            assert fmt.get_useOffset() is False and fmt.offset == 0 and '+' not in fmt.get_offset()
