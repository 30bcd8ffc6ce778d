// The tracked model's contour over the camera image (docs/web-ui.md#the-contour-over-the-camera-image):
// segments in pixels of the recorded image, projected by the server with the image's camera
// model, drawn on a canvas laid over the image and scaled to the size it is shown at.
export class ContourOverlay {
  constructor(img, canvas) {
    this.img = img;
    this.canvas = canvas;
    this.contour = null;
    new ResizeObserver(() => this.redraw()).observe(img);
    img.addEventListener('load', () => this.redraw());
  }

  /** `contour`: {segments: [u0, v0, u1, v1, ...], count}; the recorded image's size; a caption. */
  show(contour, sourceWidth, sourceHeight, label) {
    this.contour = { ...contour, sourceWidth, sourceHeight, label };
    this.canvas.dataset.segments = String(contour.count);
    this.canvas.dataset.t = String(contour.t ?? contour.pose_t ?? '');
    this.redraw();
  }

  clear() {
    this.contour = null;
    this.canvas.dataset.segments = '0';
    this.redraw();
  }

  redraw() {
    const width = this.img.clientWidth;
    const height = this.img.clientHeight;
    const ratio = window.devicePixelRatio || 1;
    this.canvas.style.width = `${width}px`;
    this.canvas.style.height = `${height}px`;
    this.canvas.width = Math.round(width * ratio);
    this.canvas.height = Math.round(height * ratio);
    const ctx = this.canvas.getContext('2d');
    ctx.clearRect(0, 0, this.canvas.width, this.canvas.height);
    const c = this.contour;
    if (!c || !c.sourceWidth || width === 0) return;
    const sx = (width * ratio) / c.sourceWidth;
    const sy = (height * ratio) / c.sourceHeight;
    ctx.strokeStyle = '#00e5ff';
    ctx.lineWidth = 1.5 * ratio;
    ctx.beginPath();
    const s = c.segments;
    for (let i = 0; i + 3 < s.length; i += 4) {
      ctx.moveTo(s[i] * sx, s[i + 1] * sy);
      ctx.lineTo(s[i + 2] * sx, s[i + 3] * sy);
    }
    ctx.stroke();
    if (c.label) {
      ctx.fillStyle = '#00e5ff';
      ctx.font = `${12 * ratio}px system-ui, sans-serif`;
      ctx.fillText(c.label, 6 * ratio, 16 * ratio);
    }
  }
}
