// Errors against time (docs/web-ui.md#errors-against-time): the position error (m, left axis) and
// the attitude error (deg, right axis) of an estimate against the truth, as `cdff eval` measures
// them, with the thresholds of the requirement that applies at each time's true range (eval's
// table, sent by the server with each error: SR_DFPC_0100 at mid range, 0101 at close range)
// drawn as dashed lines. Both axes are logarithmic: errors of millimetres and thresholds of a
// metre show together (an error of exactly 0 has no place on them and is left out).
import uPlot from 'uplot';

// A log axis's tick: 0.05, 1, 10, or 1e-4 below a hundredth.
const tick = (v) => (v === null ? '' : v >= 0.01 ? String(Number(v.toPrecision(2))) : v.toExponential(0));
const ticks = (u, splits) => splits.map(tick);

const COLUMNS = ['t', 'position_error_m', 'position_threshold_m', 'angle_error_deg', 'angle_threshold_deg'];

export class ErrorPlot {
  constructor(element) {
    this.element = element;
    this.plot = null;
    this.columns = null;
    this.requirements = [];
    this.pending = false;
  }

  /** Columns {t, position_error_m, angle_error_deg, position_threshold_m, angle_threshold_deg, requirement}. */
  show(columns, title) {
    this.title = title;
    this.columns = Object.fromEntries(COLUMNS.map((c) => [c, [...(columns[c] ?? [])]]));
    this.requirements = [...(columns.requirement ?? [])];
    this.plot?.destroy();
    this.plot = null;
    this.draw();
  }

  clear(note) {
    this.plot?.destroy();
    this.plot = null;
    this.columns = null;
    this.element.replaceChildren();
    if (note) {
      const p = document.createElement('p');
      p.className = 'note';
      p.textContent = note;
      this.element.append(p);
    }
    this.element.dataset.points = '0';
    this.element.dataset.thresholds = '{}';
  }

  /** One live error {t, error: {position_error_m, ...}}. */
  add(t, error) {
    if (!this.columns) {
      this.columns = Object.fromEntries(COLUMNS.map((key) => [key, []]));
      this.requirements = [];
    }
    const c = this.columns;
    if (c.t.length && t <= c.t.at(-1)) return;
    c.t.push(t);
    for (const key of COLUMNS.slice(1)) c[key].push(error[key] ?? null);
    this.requirements.push(error.requirement ?? '');
    if (!this.pending) {  // at most one redraw per animation frame
      this.pending = true;
      requestAnimationFrame(() => { this.pending = false; this.draw(); });
    }
  }

  draw() {
    const c = this.columns;
    const positive = (values) => values.map((v) => (v > 0 ? v : null));
    const data = COLUMNS.map((key, i) => (i === 0 ? c[key] : positive(c[key])));
    const ids = [...new Set(this.requirements.filter(Boolean))].join(', ') || 'none at these ranges';
    if (this.plot && this.plotIds !== ids) {  // the legend names the requirements drawn
      this.plot.destroy();
      this.plot = null;
    }
    if (!this.plot) {
      this.plotIds = ids;
      this.element.replaceChildren();
      this.plot = new uPlot({
        title: this.title ?? 'error against the truth',
        width: Math.max(320, this.element.clientWidth),
        height: 240,
        scales: { x: { time: false }, m: { distr: 3, log: 10 }, deg: { distr: 3, log: 10 } },
        axes: [{ label: 't (s)' }, { scale: 'm', label: 'position error (m)', values: ticks, size: 60 },
               { scale: 'deg', side: 1, label: 'attitude error (deg)', grid: { show: false }, values: ticks, size: 60 }],
        series: [
          { label: 't (s)' },
          { label: 'position error (m)', scale: 'm', stroke: '#c0392b', width: 2 },
          { label: `position threshold (m, ${ids})`, scale: 'm', stroke: '#c0392b', dash: [8, 5], width: 1.5, spanGaps: false },
          { label: 'attitude error (deg)', scale: 'deg', stroke: '#2471a3', width: 2 },
          { label: `attitude threshold (deg, ${ids})`, scale: 'deg', stroke: '#2471a3', dash: [8, 5], width: 1.5, spanGaps: false },
        ],
      }, data, this.element);
    } else {
      this.plot.setData(data);
    }
    // What the tests read: the points and the distinct thresholds drawn.
    const distinct = (values) => [...new Set(values.filter((v) => v !== null))].sort((a, b) => a - b);
    this.element.dataset.points = String(c.t.length);
    this.element.dataset.thresholds = JSON.stringify({
      position_error_m: distinct(c.position_threshold_m),
      angle_error_deg: distinct(c.angle_threshold_deg),
    });
    this.element.dataset.requirements = ids;
  }
}
