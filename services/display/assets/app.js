// Crew display page. Server-sent events announce each live frame (with its
// detections); the page then fetches that frame's image (and overlay) and
// shows image and boxes together. One fetch at a time: while it runs, newer
// announcements replace older ones, so a slow screen skips frames instead of
// falling behind. A timer shows "NO DATA" when frames stop.
'use strict';

const config = { stale_after_ms: 1000, near_distance_m: 10, mid_distance_m: 20 };
const state = {
  pending: null,        // newest announced frame not yet shown
  fetching: false,
  lastShownAt: 0,       // performance.now() of the last frame shown
  shownTimes: [],       // for frames/s
  connected: false,
  overlay: false,
  correlation: false,
  announced: 0,
  shown: 0,
  metrics: {},          // stage -> {data, at}
  status: null,
};

const $ = (id) => document.getElementById(id);

function distanceClass(d) {
  if (!(d >= 0)) return 'far';
  if (d < config.near_distance_m) return 'near';
  if (d < config.mid_distance_m) return 'mid';
  return 'far';
}

async function loadBitmap(url) {
  const res = await fetch(url, { cache: 'no-store' });
  if (!res.ok) return null;
  return createImageBitmap(await res.blob());
}

function drawInto(canvas, bitmap, width, height) {
  if (canvas.width !== width) canvas.width = width;
  if (canvas.height !== height) canvas.height = height;
  const ctx = canvas.getContext('2d');
  ctx.clearRect(0, 0, width, height);
  if (bitmap) ctx.drawImage(bitmap, 0, 0, width, height);
}

async function pump() {
  if (state.fetching || !state.pending) return;
  const ev = state.pending;
  state.pending = null;
  state.fetching = true;
  try {
    const wantOverlay = state.overlay && ev.has_labels;
    const wantCorrelation = state.correlation && ev.has_correlation;
    const [image, overlay, correlation] = await Promise.all([
      loadBitmap(`/api/frame.jpg?seq=${ev.seq}`),
      wantOverlay ? loadBitmap(`/api/overlay.png?seq=${ev.seq}`) : Promise.resolve(null),
      wantCorrelation ? loadBitmap(`/api/correlation.png?seq=${ev.seq}`) : Promise.resolve(null),
    ]);
    if (image) show(ev, image, overlay, correlation);
    for (const b of [image, overlay, correlation]) if (b) b.close();
  } catch (err) {
    // The display went away mid-fetch; the stale timer and the event stream tell the crew.
  } finally {
    state.fetching = false;
    if (state.pending) pump();
  }
}

function show(ev, image, overlay, correlation) {
  const stage = $('stage');
  stage.style.aspectRatio = `${ev.width} / ${ev.height}`;
  drawInto($('frame-canvas'), image, ev.width, ev.height);

  const overlayCanvas = $('overlay-canvas');
  drawInto(overlayCanvas, overlay, ev.width, ev.height);
  overlayCanvas.hidden = !state.overlay;
  overlayCanvas.dataset.frameSeq = overlay ? String(ev.seq) : '';
  overlayCanvas.dataset.hasContent = overlay ? 'true' : 'false';

  if (state.correlation) {
    const c = $('correlation-canvas');
    if (correlation) {
      // One canvas pixel per row and offset; shown twice as wide as tall per cell, as tall as the image.
      drawInto(c, correlation, correlation.width, correlation.height);
      c.style.aspectRatio = `${2 * correlation.width} / ${correlation.height}`;
      c.dataset.rows = String(correlation.height);
      c.dataset.offsets = String(correlation.width);
      $('correlation-max-offset').textContent = String(correlation.width - 1);
    }
    c.dataset.frameSeq = correlation ? String(ev.seq) : '';
    c.hidden = !correlation;
    $('correlation-axis').hidden = !correlation;
    $('correlation-legend').hidden = !correlation;
    $('no-correlation').hidden = !!correlation;
    fitCorrelation();
  }

  const humans = (ev.result && Array.isArray(ev.result.humans)) ? ev.result.humans.slice() : [];
  humans.sort((a, b) => (a.distance_m ?? Infinity) - (b.distance_m ?? Infinity));
  renderBoxes(humans, ev.width, ev.height);
  renderPeople(humans, !!ev.result);

  stage.dataset.frameId = ev.name ?? ev.frame;
  stage.dataset.frameKey = ev.frame;
  stage.dataset.frameSeq = String(ev.seq);
  stage.dataset.personCount = String(humans.length);
  stage.dataset.hasResult = ev.result ? 'true' : 'false';
  $('frame-id').textContent = ev.name ?? ev.frame;

  const now = performance.now();
  state.lastShownAt = now;
  if (!state.firstShownAt) state.firstShownAt = now;
  state.shown += 1;
  document.body.dataset.shown = String(state.shown);
  state.shownTimes.push(now);
  while (state.shownTimes.length && now - state.shownTimes[0] > 2000) state.shownTimes.shift();
  checkStale();
}

function renderBoxes(humans, width, height) {
  const boxes = $('boxes');
  const items = humans.map((h, i) => {
    const [l, t, r, b] = h.box;
    const el = document.createElement('div');
    const cls = distanceClass(h.distance_m);
    el.className = `person-box ${cls}` + (i === 0 ? ' nearest' : '') + (t / height < 0.12 ? ' low' : '');
    el.dataset.testid = 'person-box';
    el.setAttribute('data-testid', 'person-box');
    el.dataset.distanceM = Number(h.distance_m).toFixed(2);
    el.dataset.trackId = String(h.track_id ?? -1);
    el.dataset.box = [l, t, r, b].map((v) => Math.round(v)).join(',');
    el.style.left = `${(100 * l) / width}%`;
    el.style.top = `${(100 * t) / height}%`;
    el.style.width = `${(100 * (r - l)) / width}%`;
    el.style.height = `${(100 * (b - t)) / height}%`;
    const tag = document.createElement('div');
    tag.className = 'tag';
    const id = h.track_id >= 0 ? ` #${h.track_id}` : '';
    tag.textContent = `${Number(h.distance_m).toFixed(1)} m${id}`;
    el.appendChild(tag);
    return el;
  });
  boxes.replaceChildren(...items);
  // Nearest on top; a tag that would cover a nearer person's tag moves up a line.
  const placed = [];
  items.forEach((el, i) => {
    el.style.zIndex = String(100 - i);
    const tag = el.firstChild;
    const left = el.offsetLeft;
    const right = left + tag.offsetWidth;
    let lift = 0;
    for (let tries = 0; tries < 4; tries += 1) {
      const clash = placed.some((p) => left < p.right && right > p.left && Math.abs(p.top - (el.offsetTop - lift)) < tag.offsetHeight);
      if (!clash) break;
      lift += tag.offsetHeight;
    }
    if (lift) tag.style.transform = `translateY(-${lift}px)`;
    placed.push({ left, right, top: el.offsetTop - lift });
  });
}

function bearing(h) {
  const p = h.position_m;
  if (!Array.isArray(p) || !(p[2] > 0)) return '';
  const deg = Math.round((Math.atan2(p[0], p[2]) * 180) / Math.PI);
  if (Math.abs(deg) < 2) return 'ahead';
  return `${Math.abs(deg)}\u00b0 ${deg < 0 ? 'left' : 'right'}`;
}

function renderPeople(humans, hasResult) {
  const items = humans.map((h) => {
    const li = document.createElement('li');
    li.className = distanceClass(h.distance_m);
    li.setAttribute('data-testid', 'person-row');
    li.dataset.distanceM = Number(h.distance_m).toFixed(2);
    li.dataset.trackId = String(h.track_id ?? -1);
    const dist = document.createElement('span');
    dist.className = 'dist';
    dist.textContent = `${Number(h.distance_m).toFixed(1)} m`;
    const meta = document.createElement('span');
    meta.className = 'meta';
    meta.textContent = [h.track_id >= 0 ? `#${h.track_id}` : 'new', bearing(h)].filter(Boolean).join('  ');
    li.append(dist, meta);
    return li;
  });
  $('people-list').replaceChildren(...items.slice(0, 6));
  $('people-count').textContent = String(humans.length);
  const none = $('no-people');
  none.hidden = humans.length > 0;
  // No result is not "nobody": the detections of this frame never arrived.
  none.textContent = hasResult ? 'nobody detected' : 'NO DETECTIONS for this frame';
  none.className = hasResult ? 'muted' : 'warn-text';
  none.dataset.hasResult = hasResult ? 'true' : 'false';
}

function fmt(v, digits) {
  return typeof v === 'number' && Number.isFinite(v) ? v.toFixed(digits) : '-';
}

function latencyOf(m) {
  const l = m.latency_ms;
  if (typeof l === 'number') return l;
  if (l && typeof l === 'object') return l.p50 ?? l.median ?? l.mean;
  return undefined;
}

function dropsOf(m) {
  if (typeof m.dropped === 'number') return m.dropped;
  if (m.dropped_by_reason && typeof m.dropped_by_reason === 'object') {
    return Object.values(m.dropped_by_reason).reduce((a, b) => a + (Number(b) || 0), 0);
  }
  return undefined;
}

function renderMetrics() {
  const now = performance.now();
  const rows = Object.keys(state.metrics).sort().map((name) => {
    const { data, at } = state.metrics[name];
    const tr = document.createElement('tr');
    tr.dataset.stage = name;
    tr.setAttribute('data-testid', 'stage-row');
    if (now - at > 3000) tr.className = 'stale';
    const reasons = data.dropped_by_reason ? Object.entries(data.dropped_by_reason).map(([k, v]) => `${k}: ${v}`).join(', ') : '';
    const drops = dropsOf(data);
    const cells = [name, fmt(data.fps, 1), fmt(latencyOf(data), 1), drops === undefined ? '-' : String(drops)];
    cells.forEach((text, i) => {
      const td = document.createElement('td');
      td.textContent = text;
      if (i === 3 && drops > 0) { td.className = 'warn'; td.title = reasons; }
      tr.appendChild(td);
    });
    return tr;
  });
  // The display's own row: what this screen shows and what it skipped.
  // Frames shown in the last 2 s (or since the first one, when more recent).
  const span = Math.min(2000, now - (state.firstShownAt || now));
  const fps = span > 500 ? (1000 * state.shownTimes.filter((t) => now - t <= 2000).length) / span : 0;
  const d = state.status && state.status.display;
  const tr = document.createElement('tr');
  tr.dataset.stage = 'display';
  tr.setAttribute('data-testid', 'stage-row');
  const skipped = state.announced - state.shown;
  const serverDrops = d ? d.dropped_superseded + d.dropped_pending_full : 0;
  for (const text of ['display (this screen)', fmt(fps, 1), '-', String(serverDrops + Math.max(0, skipped))]) {
    const td = document.createElement('td');
    td.textContent = text;
    tr.appendChild(td);
  }
  rows.push(tr);
  $('stage-metrics').tBodies[0].replaceChildren(...rows);
  $('shown-fps').textContent = fmt(fps, 1);
}

function checkStale() {
  const age = performance.now() - state.lastShownAt;
  const stale = state.lastShownAt === 0 || age > config.stale_after_ms;
  const body = document.body;
  body.dataset.stale = stale ? 'true' : 'false';
  body.dataset.connected = state.connected ? 'true' : 'false';
  let text;
  if (state.lastShownAt === 0) text = state.connected ? 'NO DATA \u2014 waiting for the camera' : 'NO DATA \u2014 display not reachable';
  else text = `NO DATA \u2014 last frame ${(age / 1000).toFixed(1)} s ago` + (state.connected ? '' : ' (link lost)');
  const warning = $('stale-warning');
  if (stale && warning.textContent !== text) warning.textContent = text;
  const pill = $('link-state');
  pill.textContent = stale ? (state.connected ? 'NO DATA' : 'LINK LOST') : 'LIVE';
  pill.className = `pill ${stale ? 'pill-bad' : 'pill-ok'}`;
}

// The correlation image is as tall as the live image, so that its rows line up with the image rows.
function fitCorrelation() {
  const h = $('stage').clientHeight;
  if (h > 0) $('correlation-canvas').style.height = `${h}px`;
}

function setToggle(name, on) {
  state[name] = on;
  $(`toggle-${name}`).setAttribute('aria-pressed', on ? 'true' : 'false');
  if (name === 'overlay') {
    $('overlay-canvas').hidden = !on;
  } else {
    $('correlation-panel').hidden = !on;
    fitCorrelation();
  }
}

function connect() {
  const events = new EventSource('/api/events');
  events.onopen = () => { state.connected = true; checkStale(); };
  events.onerror = () => { state.connected = false; checkStale(); };  // EventSource retries by itself
  events.addEventListener('frame', (e) => {
    state.connected = true;
    state.announced += 1;
    state.pending = JSON.parse(e.data);
    pump();
  });
  events.addEventListener('metrics', (e) => {
    const now = performance.now();
    const stages = JSON.parse(e.data).stages || {};
    for (const [name, data] of Object.entries(stages)) {
      const old = state.metrics[name];
      if (!old || JSON.stringify(old.data) !== JSON.stringify(data)) state.metrics[name] = { data, at: now };
    }
  });
  events.addEventListener('status', (e) => {
    state.connected = true;
    state.status = JSON.parse(e.data);
  });
}

async function init() {
  try {
    const res = await fetch('/api/config', { cache: 'no-store' });
    if (res.ok) Object.assign(config, await res.json());
  } catch (err) {
    // defaults above
  }
  $('toggle-overlay').addEventListener('click', () => setToggle('overlay', !state.overlay));
  $('toggle-correlation').addEventListener('click', () => setToggle('correlation', !state.correlation));
  document.addEventListener('keydown', (e) => {
    if (e.key === 'o' || e.key === 'O') setToggle('overlay', !state.overlay);
    if (e.key === 'c' || e.key === 'C') setToggle('correlation', !state.correlation);
  });
  if (typeof ResizeObserver === 'function') new ResizeObserver(fitCorrelation).observe($('stage'));
  connect();
  setInterval(checkStale, 200);
  setInterval(renderMetrics, 500);
  checkStale();
  renderMetrics();
}

init();
