(function () {
  'use strict';
  var D = JSON.parse(document.getElementById('data').textContent);
  var COLOUR = {kept: '#2e7d32', accepted: '#2e7d32', rejected: '#c62828',
                cut: '#ef6c00', dropped: '#9e9e9e', failed: '#6d4c41'};
  var TRACKS = ['#90caf9', '#ce93d8', '#ffcc80', '#80deea', '#b0bec5', '#fff59d'];  // no red, green

  function esc(s) {
    return String(s).replace(/[&<>"]/g, function (c) {
      return {'&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;'}[c];
    });
  }
  // SVG as markup (no namespace URL needed): tag('rect', {x: 1}) or tag('g', {}, inner).
  function tag(name, attrs, inner) {
    var s = '<' + name;
    for (var k in attrs) {
      var v = attrs[k];
      s += ' ' + k + '="' + esc(typeof v === 'number' ? Math.round(v * 10) / 10 : v) + '"';
    }
    return s + (inner === undefined ? '/>' : '>' + inner + '</' + name + '>');
  }
  function tip(text) { return tag('title', {}, esc(text)); }
  function text(x, y, s, attrs) {
    var a = {x: x, y: y};
    for (var k in attrs || {}) a[k] = attrs[k];
    return tag('text', a, esc(s));
  }
  // Put an SVG of w × h units, shown `zoom` times as large, into the element `id`.
  function draw(id, cls, w, h, body, zoom) {
    var box = document.getElementById(id), z = zoom || 1;
    if (box) box.innerHTML = tag('svg', {'class': 'chart ' + cls, width: w * z, height: h * z,
                                         viewBox: '0 0 ' + w + ' ' + h}, body);
  }
  // Series come as whole steps of `unit` from the previous known value; null = unknown.
  function undelta(steps, unit) {
    var v = 0;
    return steps.map(function (s) { if (s === null) return null; v += s; return v * unit; });
  }
  function linear(d0, d1, r0, r1) {
    var k = (r1 - r0) / ((d1 - d0) || 1);
    return function (x) { return r0 + (x - d0) * k; };
  }
  function log10(d0, d1, r0, r1) {
    var f = linear(Math.log10(d0), Math.log10(d1), r0, r1);
    return function (x) { return f(Math.log10(x)); };
  }
  function ticks(lo, hi, n) {
    var raw = (hi - lo) / n || 1, mag = Math.pow(10, Math.floor(Math.log10(raw)));
    var step = mag * [1, 2, 5, 10].filter(function (m) { return m * mag >= raw; })[0];
    var out = [];
    for (var t = Math.ceil(lo / step) * step; t <= hi + step * 1e-6; t += step) {
      out.push(+t.toFixed(6));
    }
    return out;
  }
  function num(t) {
    var tiny = t && Math.abs(t) < 1e-2;
    return Math.abs(t) >= 1e4 || tiny ? t.toExponential(0) : String(+t.toFixed(2));
  }
  function xAxis(sx, ts, y, label, mid) {
    var s = '';
    ts.forEach(function (t) {
      s += tag('line', {x1: sx(t), x2: sx(t), y1: y, y2: y + 4, stroke: '#777'});
      s += text(sx(t), y + 15, num(t), {'text-anchor': 'middle'});
    });
    return s + (label ? text(mid, y + 29, label, {'text-anchor': 'middle'}) : '');
  }
  function yAxis(sy, ts, x, label, mid) {
    var s = '';
    ts.forEach(function (t) {
      s += tag('line', {x1: x - 4, x2: x, y1: sy(t), y2: sy(t), stroke: '#777'});
      s += text(x - 6, sy(t) + 4, num(t), {'text-anchor': 'end'});
    });
    var at = 'translate(' + (x - 38) + ',' + mid + ') rotate(-90)';
    return s + (label ? text(0, 0, label, {'text-anchor': 'middle', transform: at}) : '');
  }
  function frame(x, y, w, h) {
    return tag('rect', {x: x, y: y, width: w, height: h, fill: 'none', stroke: '#999'});
  }
  function path(xs, ys, sx, sy, attrs) {
    var d = '', pen = 'M';
    for (var i = 0; i < xs.length; i++) {
      if (ys[i] === null) { pen = 'M'; continue; }
      d += pen + sx(xs[i]).toFixed(1) + ',' + sy(ys[i]).toFixed(1);
      pen = 'L';
    }
    attrs.d = d || 'M0,0';
    attrs.fill = 'none';
    return tag('path', attrs);
  }
  function span(sx, r, y, h, attrs) {
    attrs.x = sx(r[0]);
    attrs.y = y;
    attrs.width = Math.max(1.5, sx(r[1]) - sx(r[0]));
    attrs.height = h;
    return attrs;
  }

  // ---------------------------------------------------------------- index
  // Whole decades around the positive values; the smallest bar stays visibly tall.
  function decades(values) {
    var ok = values.filter(function (v) { return v > 0; }).map(Math.log10);
    if (!ok.length) return null;
    var lo = Math.floor(Math.min.apply(null, ok) - 0.3), hi = Math.ceil(Math.max.apply(null, ok));
    return [Math.pow(10, lo), Math.pow(10, Math.max(hi, lo + 1))];
  }
  function powers(r) {
    var out = [];
    for (var p = r[0]; p <= r[1] * 1.0001; p *= 10) out.push(p);
    return out;
  }
  // Bars on a log axis: groups[i] = {label, href, bars: [{v, colour, opacity, tip}]}.
  var LABEL_PX = 11, TILT = 55;  // bar labels: font size, degrees below the horizontal
  function logBars(id, cls, groups, ylabel) {
    var bw = Math.max(3, Math.min(18, Math.floor(360 / groups.length))), all = [];
    groups.forEach(function (g) { g.bars.forEach(function (b) { all.push(b.v); }); });
    var range = decades(all), left = 60, top = 10, ph = 220, gw = bw * 2 + 4;
    // room below and right of the plot for the longest tilted label (~0.62 em a character)
    var labelled = groups.length <= 80, rad = TILT * Math.PI / 180;
    var longest = Math.max.apply(null, groups.map(function (g) { return g.label.length; }));
    var reach = labelled ? longest * LABEL_PX * 0.62 : 0;
    var w = Math.max(300, left + groups.length * gw + Math.max(90, reach * Math.cos(rad) + 16));
    var h = top + ph + 20 + reach * Math.sin(rad) + LABEL_PX;
    if (!range) { draw(id, cls, w, 40, text(10, 20, 'no finite jerk to plot')); return; }
    var sy = log10(range[0], range[1], top + ph, top), s = '';
    groups.forEach(function (g, i) {
      var x0 = left + i * gw + 2, bars = '';
      g.bars.forEach(function (b, k) {
        if (!(b.v > 0)) return;
        bars += tag('rect', {'class': 'bar', x: x0 + k * bw, y: sy(b.v), width: bw - 1,
                             height: top + ph - sy(b.v), fill: b.colour, opacity: b.opacity},
                    tip(b.tip));
      });
      if (labelled) {
        var at = 'translate(' + (x0 + bw) + ',' + (top + ph + 8) + ') rotate(' + TILT + ')';
        bars += text(0, 0, g.label, {transform: at, 'font-size': LABEL_PX, 'class': 'label'});
      }
      s += g.href ? tag('a', {href: g.href}, bars) : bars;
    });
    s += frame(left, top, groups.length * gw + 4, ph);
    s += yAxis(sy, powers(range), left, ylabel, top + ph / 2);
    draw(id, cls, w, h, s);
  }
  function jerkPerClip() {
    var groups = D.clips.map(function (c) {
      var c0 = COLOUR[c.status];
      return {label: c.id, href: c.href, bars: [
        {v: c.raw, colour: c0, opacity: 1, tip: c.id + ' (' + c.status + '): raw J ' + c.raw},
        {v: c.proc, colour: c0, opacity: 0.45, tip: c.id + ': processed J ' + c.proc}]};
    });
    logBars('jerk-clips', 'jerk-clips', groups, 'J (rad²/s⁵)');
  }
  function jerkPerJoint() {
    var groups = D.joints.map(function (j, i) {
      return {label: j, bars: [
        {v: D.joint_raw[i], colour: '#ef6c00', opacity: 1, tip: j + ': raw J ' + D.joint_raw[i]},
        {v: D.joint_proc[i], colour: '#1565c0', opacity: 1,
         tip: j + ': processed J ' + D.joint_proc[i]}]};
    });
    logBars('jerk-joints', 'jerk-joints', groups, 'mean J (rad²/s⁵)');
  }

  // ---------------------------------------------------------------- take page
  var ROLE_COLOUR = {speaking: '#2e7d32', listening: '#90caf9', unknown: '#e0e0e0'};
  var HEAD_COLOUR = {face: '#7e57c2', body: '#ffb74d', none: '#e0e0e0'};

  function timeline() {
    var T = D.timeline, w = 1100, left = 70, sx = linear(T.t0, T.t1, left, w - 20);
    var s = '', y = 8;
    if (T.speakers.length) {
      s += text(4, y + 14, 'speaker');
      T.speakers.forEach(function (c) {
        var fill = c.main < 0 ? '#eeeeee' : TRACKS[c.main % TRACKS.length];
        s += tag('rect', span(sx, [c.t0, c.t1], y, 20,
                              {'class': 'speaker', fill: fill, stroke: '#fff'}), tip(c.tip));
        if (sx(c.t1) - sx(c.t0) > 40) s += text(sx(c.t0) + 4, y + 14, c.label);
      });
      y += 26;
    }
    if (T.speech.measured.length) {  // speech heard (green) within the clips (grey: silence)
      s += text(4, y + 12, 'speech');
      T.speech.measured.forEach(function (m) {
        s += tag('rect', span(sx, m, y, 14, {'class': 'silence', fill: '#e0e0e0'}),
                 tip(m[0] + '–' + m[1] + ' s: speech measured (grey: no speech)'));
      });
      T.speech.heard.forEach(function (h) {
        s += tag('rect', span(sx, h, y, 14, {'class': 'speech', fill: '#66bb6a'}),
                 tip(h[0] + '–' + h[1] + ' s: speech'));
      });
      y += 20;
    }
    if (T.depth.length) {  // depth confidence: red (signs in doubt) to green (trusted)
      s += text(4, y + 12, 'depth');
      T.depth.forEach(function (d) {
        var hue = Math.round(120 * Math.max(0, Math.min(1, (d[2] - 0.5) / 0.5)));
        s += tag('rect', span(sx, d, y, 14, {'class': 'depth',
                 fill: 'hsl(' + hue + ',65%,50%)'}),
                 tip(d[0] + '–' + d[1] + ' s: depth confidence ' + d[2].toFixed(2)));
      });
      y += 20;
    }
    if ((T.head || []).length) {  // where the head came from: the face mesh or the body
      s += text(4, y + 12, 'head');
      T.head.forEach(function (h) {
        s += tag('rect', span(sx, [h[0], h[1]], y, 14, {'class': 'head ' + h[2],
                 fill: HEAD_COLOUR[h[2]]}), tip(h[0] + '–' + h[1] + ' s: head from ' + h[2]));
      });
      y += 20;
    }
    (T.people || []).forEach(function (lane) {  // who speaks when, per person
      s += text(4, y + 12, 'person ' + lane.person);
      lane.runs.forEach(function (r) {
        s += tag('rect', span(sx, [r[0], r[1]], y, 14, {'class': 'role ' + r[2],
                 fill: ROLE_COLOUR[r[2]]}), tip(r[0] + '–' + r[1] + ' s: person ' +
                 lane.person + ' ' + r[2]));
      });
      y += 20;
    });
    s += text(4, y + 15, 'clips');
    T.segments.forEach(function (g) {
      var why = g.reasons.length ? ': ' + g.reasons.join('; ') : '';
      s += tag('rect', span(sx, [g.t0, g.t1], y, 22, {'class': 'seg ' + g.kind,
               fill: COLOUR[g.kind], stroke: '#fff'}),
               tip(g.t0 + '–' + g.t1 + ' s ' + g.kind + ' ' + g.id + why));
    });
    y += 28;
    T.preview.forEach(function (t, i) {
      s += tag('path', {d: 'M' + sx(t) + ',' + y + 'l-5,9h10z', fill: '#333', 'class': 'mark'},
               tip('preview frame ' + (i + 1) + ' at ' + t + ' s'));
      s += text(sx(t), y + 20, String(i + 1), {'text-anchor': 'middle'});
    });
    y += T.preview.length ? 24 : 4;
    T.cuts.forEach(function (t) {
      s += tag('line', {'class': 'cut', x1: sx(t), x2: sx(t), y1: 2, y2: y, stroke: '#000',
                        'stroke-dasharray': '4 3'}, tip('shot cut at ' + t + ' s'));
    });
    s += tag('line', {x1: left, x2: w - 20, y1: y, y2: y, stroke: '#777'});
    s += xAxis(sx, ticks(T.t0, T.t1, 12), y, 'source time (s)', (left + w) / 2);
    draw('timeline', 'timeline', w, y + 36, s);
  }

  function preview() {
    var P = D.preview;
    if (!P) return;
    var s = tag('image', {href: P.src, x: 0, y: 0, width: P.w, height: P.h});
    P.frames.forEach(function (f, i) {
      var x0 = i * P.fw;
      if (f.points) {
        D.bones.forEach(function (b) {
          var p = f.points[b[0]], q = f.points[b[1]];
          if (p && q) {
            s += tag('line', {'class': 'bone', x1: p[0], y1: p[1], x2: q[0], y2: q[1],
                              stroke: b[2] ? '#00e5ff' : '#ff9100', 'stroke-width': 1.5});
          }
        });
        f.points.forEach(function (p, k) {
          if (!p) return;
          var fixed = f.repaired[k];
          s += tag('circle', {'class': 'joint', cx: p[0], cy: p[1], r: fixed ? 2.5 : 1.8,
                              fill: fixed ? '#ff1744' : '#fff', stroke: '#000'},
                   tip(D.keypoints[k] + (fixed ? ' (repaired)' : '')));
        });
      } else {
        var mid = {'text-anchor': 'middle', fill: '#fff', 'font-size': 12};
        s += tag('rect', {x: x0, y: 0, width: P.fw, height: P.h, fill: '#000', opacity: 0.45},
                 tip(f.note));
        s += text(x0 + P.fw / 2, P.h / 2 - 8, 'no skeleton', mid);
        s += text(x0 + P.fw / 2, P.h / 2 + 8, f.note.split(':')[0], mid);
      }
      s += tag('rect', {x: x0 + 2, y: 2, width: Math.min(P.fw - 4, 150), height: 17,
                        fill: '#fff', opacity: 0.85});
      s += text(x0 + 6, 15, (i + 1) + ' · ' + f.t.toFixed(2) + ' s');
    });
    draw('preview', 'preview', P.w, P.h, s, Math.max(1, Math.min(2, 1100 / P.w)));
  }

  function anglePlots(c, n) {
    var cols = 4, pw = 250, ph = 120, ml = 48, mt = 20, mb = 34, cw = pw + ml + 12;
    var sx = linear(c.t0, c.t1, 0, pw), tr = undelta(c.raw.t, 0.001), s = '';
    var tp = (c.proc.v[0] || []).map(function (_, i) { return c.proc.t0 + i * c.proc.dt; });
    D.joints.forEach(function (name, j) {
      var bx = (j % cols) * cw + ml, by = Math.floor(j / cols) * (ph + mt + mb) + mt;
      var raw = undelta(c.raw.v[j], 0.1), proc = undelta(c.proc.v[j], 0.1);
      // the limits and the data, but no more than half the limits' range beyond them
      var known = raw.concat(proc).filter(function (v) { return v !== null; });
      var room = (D.upper[j] - D.lower[j]) / 2;
      var lo = Math.max(D.lower[j] - room, Math.min.apply(null, known.concat([D.lower[j]])));
      var hi = Math.min(D.upper[j] + room, Math.max.apply(null, known.concat([D.upper[j]])));
      var pad = (hi - lo) * 0.05 || 1, toY = linear(lo - pad, hi + pad, by + ph, by);
      var sy = function (v) { return toY(Math.max(lo - pad, Math.min(hi + pad, v))); };
      var px = function (t) { return bx + sx(t); }, g = '';
      c.masked[j].forEach(function (r) {
        g += tag('rect', span(px, r, by, ph, {'class': 'masked', fill: '#d7ccc8'}),
                 tip('masked (angle unknown) ' + r[0] + '–' + r[1] + ' s'));
      });
      [D.lower[j], D.upper[j]].forEach(function (v) {
        g += tag('line', {'class': 'limit', x1: bx, x2: bx + pw, y1: sy(v), y2: sy(v),
                          stroke: '#c62828', 'stroke-dasharray': '5 3'}, tip('limit ' + v + '°'));
      });
      g += path(tr, raw, px, sy, {'class': 'raw', stroke: '#9e9e9e', 'stroke-width': 1});
      g += path(tp, proc, px, sy, {'class': 'proc', stroke: '#1565c0', 'stroke-width': 1.5});
      c.repaired[j].forEach(function (r) {
        g += tag('rect', span(px, r, by + ph - 6, 6, {'class': 'repaired', fill: '#ff1744'}),
                 tip('repaired ' + r[0] + '–' + r[1] + ' s'));
      });
      g += frame(bx, by, pw, ph) + text(bx + 4, by - 6, name, {'font-weight': 'bold'});
      g += xAxis(px, ticks(c.t0, c.t1, 6), by + ph, j >= 7 ? 'source time (s)' : '', bx + pw / 2);
      g += yAxis(sy, ticks(lo - pad, hi + pad, 4), bx, j % cols ? '' : 'angle (°)', by + ph / 2);
      s += tag('g', {'class': 'joint-plot', 'data-joint': name}, g);
    });
    var lx = 3 * cw + ml, ly = 2 * (ph + mt + mb) + mt + 10, items = [
      ['line', '#9e9e9e', 'raw (video frames)'], ['line', '#1565c0', 'processed (100 Hz)'],
      ['dash', '#c62828', 'robot limits'], ['box', '#d7ccc8', 'masked: angle unknown'],
      ['box', '#ff1744', 'repaired keypoints']];
    items.forEach(function (it, i) {
      var y = ly + i * 20;
      s += it[0] === 'box' ? tag('rect', {x: lx, y: y - 8, width: 22, height: 10, fill: it[1]})
        : tag('line', {x1: lx, x2: lx + 22, y1: y - 3, y2: y - 3, stroke: it[1], 'stroke-width': 2,
                       'stroke-dasharray': it[0] === 'dash' ? '5 3' : 'none'});
      s += text(lx + 28, y, it[2]);
    });
    draw('angles-' + n, 'angles', cols * cw, 3 * (ph + mt + mb), s);
  }

  // ---------------------------------------------------------------- tables
  function key(cell) {
    var v = cell.getAttribute('data-v');
    if (v === null) return cell.textContent;
    return v !== '' && isFinite(v) ? Number(v) : v;
  }
  function sortable(table) {
    var heads = Array.prototype.slice.call(table.tHead.rows[0].cells);
    heads.forEach(function (th, col) {
      th.addEventListener('click', function () {
        var down = th.getAttribute('aria-sort') === 'ascending';
        heads.forEach(function (h) { h.removeAttribute('aria-sort'); });
        th.setAttribute('aria-sort', down ? 'descending' : 'ascending');
        var body = table.tBodies[0], rows = Array.prototype.slice.call(body.rows);
        rows.sort(function (a, b) {
          var x = key(a.cells[col]), y = key(b.cells[col]), c;
          if (typeof x !== typeof y) c = typeof x === 'number' ? 1 : -1;
          else c = typeof x === 'number' ? x - y : x.localeCompare(y);
          return down ? -c : c;
        });
        rows.forEach(function (r) { body.appendChild(r); });
      });
    });
  }

  if (D.page === 'index') {
    jerkPerClip();
    jerkPerJoint();
  } else if (D.page === 'take') {
    timeline();
    preview();
    D.clips.forEach(anglePlots);
  }
  document.querySelectorAll('table.sortable').forEach(sortable);
})();
