// A pose channel's position against time (uPlot), with a line at the replay's time.
import uPlot from 'uplot';
import 'uplot/dist/uPlot.min.css';

export class PositionPlot {
  constructor(element) {
    this.element = element;
    this.plot = null;
    this.time = 0;
  }

  /** Shows `poses` ({t, x, y, z, frame, child_frame}) of `channel`. */
  show(channel, poses) {
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
    this.plot = new uPlot(options, [poses.t, poses.x, poses.y, poses.z], this.element);
    this.element.dataset.points = String(poses.t.length);
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
