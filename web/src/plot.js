// A pose channel's position against time (uPlot), with a line at the replay's time; with an
// estimate of the same transform, the estimate (solid) against the channel (dashed): the
// trajectories, truth against estimate.
import uPlot from 'uplot';
import 'uplot/dist/uPlot.min.css';

export class PositionPlot {
  constructor(element) {
    this.element = element;
    this.plot = null;
    this.time = 0;
  }

  /**
   * Shows `poses` ({t, x, y, z, frame, child_frame}) of `channel`, and `estimate` ({channel,
   * poses}) beside it when given.
   */
  show(channel, poses, estimate = null) {
    this.plot?.destroy();
    const marker = {
      hooks: {
        draw: [(u) => {
          const x = u.valToPos(this.time, 'x', true);
          const { ctx } = u;
          ctx.save();
          ctx.strokeStyle = '#d33';
          ctx.lineWidth = 2;
          ctx.beginPath();
          ctx.moveTo(x, u.bbox.top);
          ctx.lineTo(x, u.bbox.top + u.bbox.height);
          ctx.stroke();
          ctx.restore();
        }],
      },
    };
    const options = {
      title: `${channel}: position of ${poses.child_frame || 'the child frame'} in ${poses.frame || 'its parent'} (m)`,
      width: Math.max(320, this.element.clientWidth),
      height: 260,
      scales: { x: { time: false } },
      axes: [{ label: 't (s)' }, { label: 'm' }],
      series: [
        { label: 't (s)' },
        { label: 'x', stroke: '#c0392b' },
        { label: 'y', stroke: '#27ae60' },
        { label: 'z', stroke: '#2980b9' },
      ],
      plugins: [marker],
    };
    let data = [poses.t, poses.x, poses.y, poses.z];
    if (estimate) {
      const e = estimate.poses;
      options.title = `${estimate.channel} (solid) and ${channel} (dashed): position of ${poses.child_frame} in ${poses.frame} (m)`;
      options.series = [{ label: 't (s)' }];
      for (const [axis, colour] of [['x', '#c0392b'], ['y', '#27ae60'], ['z', '#2980b9']]) {
        options.series.push({ label: `${axis} estimate`, stroke: colour, width: 2, spanGaps: true });
      }
      for (const [axis, colour] of [['x', '#c0392b'], ['y', '#27ae60'], ['z', '#2980b9']]) {
        options.series.push({ label: `${axis} ${channel}`, stroke: colour, dash: [6, 4], spanGaps: true });
      }
      data = uPlot.join([[e.t, e.x, e.y, e.z], [poses.t, poses.x, poses.y, poses.z]]);
    }
    this.plot = new uPlot(options, data, this.element);
    this.element.dataset.points = String(poses.t.length);
    this.element.dataset.estimates = String(estimate ? estimate.poses.t.length : 0);
  }

  clear() {
    this.plot?.destroy();
    this.plot = null;
    this.element.dataset.points = '0';
  }

  /** Moves the time line. */
  setTime(t) {
    this.time = t;
    this.plot?.redraw(false, false);
  }
}

// Chaser and target trajectories in LVLH against time: the chaser's truth (dotted), the target's
// truth (dashed) and its estimate (solid: the estimated servicer_T_target through the chaser's
// true lvlh_T_servicer, composed by the server).
export class LvlhPlot {
  constructor(element) {
    this.element = element;
    this.plot = null;
  }

  /** Each {t, x, y, z} or null: `chaser`, `target` (truth), `estimate`; `names` their channels. */
  show(chaser, target, estimate, names) {
    this.plot?.destroy();
    this.plot = null;
    const tables = [];
    const series = [{ label: 't (s)' }];
    const axes = [['x', '#c0392b'], ['y', '#27ae60'], ['z', '#2980b9']];
    for (const [track, name, style] of [[chaser, names.chaser, { dash: [2, 3] }],
                                        [target, names.target, { dash: [6, 4] }],
                                        [estimate, names.estimate, { width: 2 }]]) {
      if (!track) continue;
      tables.push([track.t, track.x, track.y, track.z]);
      for (const [axis, colour] of axes) series.push({ label: `${axis} ${name}`, stroke: colour, spanGaps: true, ...style });
    }
    this.element.dataset.chaser = String(chaser?.t.length ?? 0);
    this.element.dataset.target = String(target?.t.length ?? 0);
    this.element.dataset.estimate = String(estimate?.t.length ?? 0);
    if (tables.length === 0) {
      this.element.replaceChildren();
      return;
    }
    this.plot = new uPlot({
      title: 'trajectories in LVLH (m): chaser (dotted), target truth (dashed), target estimate (solid)',
      width: Math.max(320, this.element.clientWidth),
      height: 260,
      scales: { x: { time: false } },
      axes: [{ label: 't (s)' }, { label: 'm' }],
      series,
    }, tables.length === 1 ? tables[0] : uPlot.join(tables), this.element);
  }
}
