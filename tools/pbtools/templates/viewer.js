{% raw %}
// The image viewer of the report (pbtools/viewer.py gathers its images). Per scene: a cell's output,
// the reference and the cell's FLIP map in three panels under one zoom and pan, or one of them alone
// in one large panel, so that switching flips between images at the same place.
//   1-9: the cell    t / r / f: its image, the reference, its FLIP map alone    a: all three
//   [ and ] (or left/right arrows): the previous / next metric frame
//   wheel: zoom about the pointer (pixels magnified, never smoothed)    drag: pan    0 or double-click: reset
//   - and + (or =): exposure one stop down / up, over the stops pbtools/viewer.py wrote (-2..+2 EV) for
//                   the outputs and the reference (never the FLIP maps); the buttons pick a stop
//   s: swipe mode: two images (any of the reference, the outputs, the FLIP maps; A and B menus, 1-9
//      puts that cell's output in A) in one panel, split by a vertical divider that follows the pointer
// Keys go to the viewer under the pointer, or the one last clicked. The state is mirrored in the
// viewer's data-* attributes (cell, frame, show, zoom, x, y, ev, swipeA, swipeB, split), which a test
// reads back.
(function () {
  'use strict';
  var PANELS = ['image', 'reference', 'flip'];
  var TITLES = {image: 'output', reference: 'reference', flip: 'FLIP map'};
  var ZOOM_STEP = 1.25, MAX_ZOOM = 64;
  var active = null;

  function Viewer(root) {
    this.root = root;
    this.data = JSON.parse(root.querySelector('.viewer-data').textContent);
    this.state = {cell: 0, frame: this.data.frames.length - 1, show: 'all', zoom: 1, x: 0, y: 0, ev: 0,
                  swipeA: 'image:0', swipeB: 'reference', split: 0.5};
    this.stops = this.data.stops || [0];
    this.stage = root.querySelector('.viewer-stage');
    this.frameSelect = root.querySelector('.viewer-frame');
    this.status = root.querySelector('.viewer-status');
    this.panels = {};
    var self = this;
    PANELS.forEach(function (kind) {
      var panel = document.createElement('div');
      panel.className = 'viewer-panel';
      var img = document.createElement('img');
      img.alt = TITLES[kind];
      img.draggable = false;
      var caption = document.createElement('div');
      caption.className = 'viewer-caption';
      panel.appendChild(img);
      panel.appendChild(caption);
      self.stage.appendChild(panel);
      self.panels[kind] = {panel: panel, img: img, caption: caption};
      self.bindPointer(panel);
    });
    this.swipe = this.buildSwipe();
    root.querySelectorAll('[data-ev]').forEach(function (button) {
      button.addEventListener('click', function () { self.set({ev: +button.dataset.ev}); });
    });
    root.querySelectorAll('select[data-swipe]').forEach(function (select) {
      select.addEventListener('change', function () {
        var change = {};
        change[select.dataset.swipe === 'a' ? 'swipeA' : 'swipeB'] = select.value;
        self.set(change);
      });
    });
    root.querySelectorAll('[data-cell]').forEach(function (button) {
      button.addEventListener('click', function () { self.set({cell: +button.dataset.cell}); });
    });
    root.querySelectorAll('[data-show]').forEach(function (button) {
      button.addEventListener('click', function () { self.set({show: button.dataset.show}); });
    });
    this.frameSelect.addEventListener('change', function () {
      self.set({frame: +self.frameSelect.value});
    });
    root.addEventListener('mouseenter', function () { active = self; });
    root.addEventListener('mousedown', function () { active = self; });
    root.addEventListener('focus', function () { active = self; });
    root.hidden = false;
    this.render();
  }

  // The swipe panel: image A below, image B above it clipped to the right of the divider; both under
  // the viewer's one zoom and pan.
  Viewer.prototype.buildSwipe = function () {
    var self = this, panel = document.createElement('div');
    panel.className = 'viewer-panel viewer-single viewer-swipe';
    var a = document.createElement('img'), cover = document.createElement('div');
    var b = document.createElement('img'), divider = document.createElement('div');
    var caption = document.createElement('div');
    a.draggable = b.draggable = false;
    a.alt = 'swipe A';
    b.alt = 'swipe B';
    cover.className = 'viewer-swipe-b';
    divider.className = 'viewer-divider';
    caption.className = 'viewer-caption';
    cover.appendChild(b);
    panel.appendChild(a);
    panel.appendChild(cover);
    panel.appendChild(divider);
    panel.appendChild(caption);
    this.stage.appendChild(panel);
    this.bindPointer(panel);
    panel.addEventListener('pointermove', function (e) {
      if (e.buttons) return;  // a drag pans
      var r = panel.getBoundingClientRect();
      if (r.width) self.set({split: Math.min(1, Math.max(0, (e.clientX - r.left) / r.width))});
    });
    return {panel: panel, a: a, b: b, cover: cover, divider: divider, caption: caption};
  };

  // A source named 'reference', 'image:<cell>' or 'flip:<cell>' at the current frame and exposure:
  // {src, label}.
  Viewer.prototype.source = function (name) {
    var frame = this.data.frames[this.state.frame], ev = String(this.state.ev);
    if (name === 'reference') {
      return {src: (frame.reference_stops || {})[ev] || frame.reference, label: 'reference'};
    }
    var parts = name.split(':'), i = +parts[1], cell = frame.cells[i], label = this.data.cells[i].label;
    if (parts[0] === 'flip') return {src: cell.flip, label: 'FLIP map of ' + label};
    return {src: (cell.image_stops || {})[ev] || cell.image, label: label};
  };

  Viewer.prototype.stepExposure = function (direction) {
    var at = this.stops.indexOf(this.state.ev);
    var next = Math.min(this.stops.length - 1, Math.max(0, at + direction));
    this.set({ev: this.stops[next]});
  };

  Viewer.prototype.set = function (change) {
    for (var key in change) this.state[key] = change[key];
    this.render();
  };

  // Zoom by `factor` keeping the point at (u, v) (fractions of a panel) where it is.
  Viewer.prototype.zoomAt = function (factor, u, v) {
    var s = this.state;
    var zoom = Math.min(MAX_ZOOM, Math.max(1, s.zoom * factor));
    var k = zoom / s.zoom;
    this.set({zoom: zoom, x: u - (u - s.x) * k, y: v - (v - s.y) * k});
  };

  Viewer.prototype.bindPointer = function (panel) {
    var self = this, drag = null;
    panel.addEventListener('wheel', function (e) {
      e.preventDefault();
      var r = panel.getBoundingClientRect();
      // A panel whose image has not loaded yet has no height: zoom about its middle then.
      self.zoomAt(e.deltaY < 0 ? ZOOM_STEP : 1 / ZOOM_STEP, r.width ? (e.clientX - r.left) / r.width : 0.5,
                  r.height ? (e.clientY - r.top) / r.height : 0.5);
    }, {passive: false});
    panel.addEventListener('pointerdown', function (e) {
      var r = panel.getBoundingClientRect();
      drag = {x: e.clientX, y: e.clientY, sx: self.state.x, sy: self.state.y, w: r.width, h: r.height};
      if (panel.setPointerCapture) panel.setPointerCapture(e.pointerId);
    });
    panel.addEventListener('pointermove', function (e) {
      if (!drag) return;
      self.set({x: drag.sx + (e.clientX - drag.x) / drag.w, y: drag.sy + (e.clientY - drag.y) / drag.h});
    });
    panel.addEventListener('pointerup', function () { drag = null; });
    panel.addEventListener('dblclick', function () { self.set({zoom: 1, x: 0, y: 0}); });
  };

  Viewer.prototype.key = function (e) {
    var k = e.key, s = this.state, frames = this.data.frames.length;
    if (k >= '1' && k <= '9') {
      var cell = +k - 1;
      if (cell < this.data.cells.length) {
        this.set(s.show === 'swipe' ? {cell: cell, swipeA: 'image:' + cell} : {cell: cell});
      }
    } else if (k === 't') this.set({show: 'image'});
    else if (k === 's') this.set({show: 'swipe'});
    else if (k === '-') this.stepExposure(-1);
    else if (k === '+' || k === '=') this.stepExposure(1);
    else if (k === 'r') this.set({show: 'reference'});
    else if (k === 'f') this.set({show: 'flip'});
    else if (k === 'a') this.set({show: 'all'});
    else if (k === '0') this.set({zoom: 1, x: 0, y: 0});
    else if (k === ']' || k === 'ArrowRight') this.set({frame: Math.min(frames - 1, s.frame + 1)});
    else if (k === '[' || k === 'ArrowLeft') this.set({frame: Math.max(0, s.frame - 1)});
    else return false;
    return true;
  };

  Viewer.prototype.render = function () {
    var s = this.state, frame = this.data.frames[s.frame], cell = frame.cells[s.cell];
    var label = this.data.cells[s.cell].label;
    var ev = String(s.ev);
    var sources = {image: (cell.image_stops || {})[ev] || cell.image,
                   reference: (frame.reference_stops || {})[ev] || frame.reference, flip: cell.flip};
    var captions = {image: label, reference: 'reference',
                    flip: 'FLIP map of ' + label + (cell.score ? ' (' + cell.score + ')' : '')};
    var transform = 'translate(' + (s.x * 100) + '%, ' + (s.y * 100) + '%) scale(' + s.zoom + ')';
    for (var i = 0; i < PANELS.length; i++) {
      var kind = PANELS[i], p = this.panels[kind];
      var shown = s.show === 'all' || s.show === kind;
      p.panel.hidden = !shown;
      p.panel.className = 'viewer-panel' + (s.show === 'all' ? '' : ' viewer-single');
      if (!shown) continue;
      if (sources[kind]) {
        if (p.img.getAttribute('src') !== sources[kind]) p.img.setAttribute('src', sources[kind]);
        p.img.hidden = false;
      } else {
        p.img.hidden = true;
      }
      p.img.style.transform = transform;
      p.caption.textContent = sources[kind] ? captions[kind] : captions[kind] + ': no image';
    }
    var w = this.swipe, swiping = s.show === 'swipe';
    w.panel.hidden = !swiping;
    // The swipe images get their sources while hidden too: an image element without one reads as
    // broken.
    var a = this.source(s.swipeA), b = this.source(s.swipeB);
    [[w.a, a], [w.b, b]].forEach(function (pair) {
      if (pair[1].src && pair[0].getAttribute('src') !== pair[1].src) pair[0].setAttribute('src', pair[1].src);
      pair[0].hidden = !pair[1].src;
    });
    if (swiping) {
      [w.a, w.b].forEach(function (img) { img.style.transform = transform; });
      var at = (s.split * 100).toFixed(2) + '%';
      w.cover.style.clipPath = 'inset(0 0 0 ' + at + ')';
      w.divider.style.left = at;
      w.caption.textContent = 'A: ' + a.label + ' | B: ' + b.label;
    }
    this.root.querySelectorAll('select[data-swipe]').forEach(function (select) {
      select.value = select.dataset.swipe === 'a' ? s.swipeA : s.swipeB;
    });
    this.root.querySelectorAll('[data-ev]').forEach(function (b) {
      b.classList.toggle('on', +b.dataset.ev === s.ev);
    });
    this.frameSelect.value = String(s.frame);
    this.root.querySelectorAll('[data-cell]').forEach(function (b) {
      b.classList.toggle('on', +b.dataset.cell === s.cell);
    });
    this.root.querySelectorAll('[data-show]').forEach(function (b) {
      b.classList.toggle('on', b.dataset.show === s.show);
    });
    this.status.textContent = 'frame ' + frame.frame + ', zoom ' + s.zoom.toFixed(2) + 'x, exposure ' +
        (s.ev > 0 ? '+' : '') + s.ev + ' EV';
    var d = this.root.dataset;
    d.cell = s.cell; d.frame = frame.frame; d.show = s.show;
    d.zoom = s.zoom.toFixed(4); d.x = s.x.toFixed(4); d.y = s.y.toFixed(4);
    d.ev = s.ev; d.swipeA = s.swipeA; d.swipeB = s.swipeB; d.split = s.split.toFixed(4);
  };

  var viewers = [];
  document.querySelectorAll('.viewer[data-viewer]').forEach(function (root) {
    viewers.push(new Viewer(root));
  });
  document.addEventListener('keydown', function (e) {
    if (e.ctrlKey || e.metaKey || e.altKey) return;
    var tag = e.target && e.target.tagName;
    if (tag === 'INPUT' || tag === 'TEXTAREA' || tag === 'SELECT') return;
    var viewer = active || (viewers.length === 1 ? viewers[0] : null);
    if (viewer && viewer.key(e)) e.preventDefault();
  });
  window.pbViewers = viewers;
})();
{% endraw %}
