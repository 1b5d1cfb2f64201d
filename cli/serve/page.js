'use strict';
// raylink studio's page: follows the server's state (server-sent events), fetches each new
// image as linear floats and tone-maps it here, and sends camera moves, relights and saves.
// Reads change nothing on the server: whatever the page wants computed, it asks for by POST.
// `window.studio` holds what the page received, for tests and the console.

const token = new URLSearchParams(location.search).get('token');
const $ = (id) => document.getElementById(id);

const studio = window.studio = {
  state: null,
  image: null,       // {kind, width, height, data: Float32Array, version, spp}
  reference: null,
  history: [],       // every beauty image drawn: {version, spp, view, mean, canvas}
  commands: 0,       // commands answered
};

function url(path, params = {}) {
  const u = new URL(path, location.href);
  if (token) u.searchParams.set('token', token);
  for (const [k, v] of Object.entries(params)) u.searchParams.set(k, v);
  return u.toString();
}

async function post(path, body) {
  const response = await fetch(url(path), {
    method: 'POST',
    headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify(body),
  });
  const text = await response.text();
  studio.commands++;
  if (!response.ok) throw new Error(text.trim());
  return JSON.parse(text);
}

function showError(e) {
  $('error').hidden = false;
  $('error').textContent = e.message;
}

// ---- images -------------------------------------------------------------------------

async function fetchImage(kind) {
  const response = await fetch(url('/api/image', { kind }));
  if (!response.ok) return null;
  const buffer = await response.arrayBuffer();
  return {
    kind,
    width: +response.headers.get('X-Width'),
    height: +response.headers.get('X-Height'),
    version: +response.headers.get('X-Version'),
    spp: +response.headers.get('X-Spp'),
    view: +response.headers.get('X-View'),
    data: new Float32Array(buffer),
  };
}

function mean(data) {
  let sum = 0;
  for (let i = 0; i < data.length; i++) sum += data[i];
  return sum / data.length;
}

let fetching = false, again = false, askingAovs = false;
// Fetches the image the controls ask for if it is not the one shown; one fetch at a time.
async function refresh() {
  if (fetching) { again = true; return; }
  const s = studio.state;
  if (!s) return;
  const kind = $('kind').value;
  // The retrace map comes with each frame's image.
  const withImage = kind === 'beauty' || kind === 'retrace';
  const wanted = withImage ? s.image_version : s.view;
  const have = studio.image;
  if (withImage && s.image_version === 0) return;
  if (kind === 'retrace' && s.retraced == null) return;
  if (!withImage && !s.aovs) {
    // The auxiliary images, once asked for, are computed for every view after.
    if (!s.aovs_wanted && !askingAovs) {
      askingAovs = true;
      post('/api/aovs', { wanted: true }).catch(showError).finally(() => { askingAovs = false; });
    }
    return;
  }
  if (have && have.kind === kind && have.version === wanted) return;
  fetching = true;
  try {
    const image = await fetchImage(kind);
    if (image && image.data.length === image.width * image.height * 3) {
      studio.image = image;
      draw();
      if (kind === 'beauty') {
        studio.history.push({ version: image.version, spp: image.spp, view: image.view,
                              mean: mean(image.data), canvas: studio.canvasStats().hash });
      }
    }
  } finally {
    fetching = false;
    if (again) { again = false; refresh(); }
  }
}

// ---- tone mapping -------------------------------------------------------------------

const srgb = (v) => v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055;
// Narkowicz's fit of the ACES filmic curve.
const filmic = (v) => (v * (2.51 * v + 0.03)) / (v * (2.43 * v + 0.59) + 0.14);

function draw() {
  const image = studio.image;
  if (!image) return;
  const canvas = $('canvas');
  const { width, height, data, kind } = image;
  if (canvas.width !== width || canvas.height !== height) {
    canvas.width = width; canvas.height = height;
  }
  const ctx = canvas.getContext('2d');
  const out = ctx.createImageData(width, height);
  const scale = Math.pow(2, +$('exposure').value);
  const tone = $('tone').value;
  let depthMax = 0;
  if (kind === 'depth') {
    for (let i = 0; i < data.length; i++) if (isFinite(data[i])) depthMax = Math.max(depthMax, data[i]);
  }
  const ref = studio.reference;
  const split = kind === 'beauty' && $('split').checked && ref && ref.width === width
    ? Math.round(+$('split-at').value * width) : width;
  for (let y = 0; y < height; y++) {
    for (let x = 0; x < width; x++) {
      const i = (y * width + x) * 3, o = (y * width + x) * 4;
      const src = x >= split ? ref.data : data;
      for (let c = 0; c < 3; c++) {
        let v = src[i + c];
        if (kind === 'normal') v = 0.5 * v + 0.5;
        else if (kind === 'depth') v = depthMax > 0 && isFinite(v) ? v / depthMax : 0;
        else {
          v *= scale;
          if (tone === 'srgb') v = srgb(Math.min(Math.max(v, 0), 1));
          else if (tone === 'filmic') v = srgb(Math.min(Math.max(filmic(Math.max(v, 0)), 0), 1));
        }
        out.data[o + c] = Math.round(Math.min(Math.max(v, 0), 1) * 255);
      }
      out.data[o + 3] = 255;
    }
  }
  ctx.putImageData(out, 0, 0);
  if (split < width) {
    ctx.fillStyle = '#fff';
    ctx.fillRect(split, 0, 1, height);
  }
}

// The canvas's pixels, summed: what the page shows (for tests).
studio.canvasStats = () => {
  const c = $('canvas');
  const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
  let sum = 0, hash = 0;
  for (let i = 0; i < d.length; i++) {
    if ((i & 3) === 3) continue;
    sum += d[i];
    hash = (hash * 31 + d[i]) >>> 0;
  }
  return { width: c.width, height: c.height, mean: sum / (c.width * c.height * 3), hash };
};

// ---- state --------------------------------------------------------------------------

const fmt = (v, digits = 2) => v == null ? '–' : (+v).toFixed(digits);
// Samples per pixel: a mean with a fraction in the middle of a pass.
const sppText = (v) => Number.isInteger(v) ? `${v}` : v.toFixed(1);

function figures(s) {
  const rows = [
    ['integrator', s.integrator + (s.spectral ? ' (spectral)' : '')],
    ['samples', s.progressive ? `${sppText(s.spp)} / ${s.target_spp} spp`
      : s.status === 'done' ? 'done' : s.image_version ? 'preview: 1 a pixel' : '…'],
    ['elapsed', `${fmt(s.elapsed)} s`],
    ['ETA', s.eta == null ? '–' : `${fmt(s.eta, 1)} s`],
    ['Mrays/s', fmt(s.mrays)],
    ['camera → image', s.view_ms == null ? '–' : `${fmt(s.view_ms, 0)} ms`],
    ['relight → image', s.relight_ms == null ? '–' : `${fmt(s.relight_ms, 0)} ms`],
    ['relight alone', s.relight_prepare_ms == null ? '–' : `${fmt(s.relight_prepare_ms, 0)} ms`],
  ];
  if (s.retraced != null) rows.push(['retraced', `${fmt(s.retraced * 100, 1)}% of the pixels`]);
  if (s.reference) rows.push(['RMSE vs reference', s.rmse == null ? '–' : s.rmse.toPrecision(4)]);
  const dl = $('figures');
  dl.replaceChildren();
  for (const [k, v] of rows) {
    const dt = document.createElement('dt'); dt.textContent = k;
    const dd = document.createElement('dd'); dd.textContent = v;
    dl.append(dt, dd);
  }
}

function onState(s) {
  const first = !studio.state;
  studio.state = s;
  if (first) setup(s);
  const what = s.progressive ? `${sppText(s.spp)}/${s.target_spp} spp` : s.phase;
  $('status').textContent = `${s.status} · ${what} · ${fmt(s.elapsed, 1)} s` +
    (s.eta != null ? ` · ETA ${fmt(s.eta, 1)} s` : '') +
    (s.mrays != null ? ` · ${fmt(s.mrays)} Mrays/s` : '');
  $('error').hidden = !s.error;
  $('error').textContent = s.error || '';
  figures(s);
  $('undo-view').disabled = !s.back_steps;
  if (!dragging) camera = s.camera;
  refresh();
}

function slider(parent, label, value, max, send) {
  const wrap = document.createElement('label');
  wrap.className = 'slider';
  const out = document.createElement('output');
  out.textContent = value.toFixed(2);
  const input = document.createElement('input');
  Object.assign(input, { type: 'range', min: 0, max, step: 0.01, value });
  input.dataset.name = label;
  input.addEventListener('input', () => { out.textContent = (+input.value).toFixed(2); send(); });
  wrap.append(`${label} `, out, input);
  parent.append(wrap);
  return input;
}

// A colour input beside a slider: its linear RGB (sRGB decoded), white by default.
const linear = (c) => c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4);
const hex = (rgb) => '#' + rgb.map((v) =>
  Math.round(srgb(Math.min(Math.max(v, 0), 1)) * 255).toString(16).padStart(2, '0')).join('');
function colourInput(parent, label, rgb, send, touched) {
  const input = document.createElement('input');
  Object.assign(input, { type: 'color', value: hex(rgb), title: `${label} colour` });
  input.dataset.name = `${label} colour`;
  // A colour given before (a tint in the server's state) is kept.
  if (touched) input.dataset.touched = '1';
  // Until it is touched, the colour (rounded to 8 bits a channel) is not sent.
  input.addEventListener('input', () => { input.dataset.touched = '1'; send(); });
  parent.lastChild.append(input);
  return input;
}
const colourOf = (input) => [1, 3, 5].map((i) => linear(parseInt(input.value.slice(i, i + 2), 16) / 255));

// Relight controls: per light a strength and a colour; per material a factor on its colour
// and a colour that replaces it.
const lightInputs = {}, materialInputs = {};
function relightBody(s) {
  const lights = {}, materials = {};
  for (const [n, { strength, colour }] of Object.entries(lightInputs)) {
    lights[n] = colour.dataset.touched
      ? colourOf(colour).map((c) => +strength.value * c) : +strength.value;
  }
  for (const m of s.materials) {
    const { factor, colour } = materialInputs[m.name];
    if (!colour.dataset.touched) { materials[m.name] = +factor.value; continue; }
    const picked = colourOf(colour);
    // The factor on each channel of the material's own colour that gives the colour picked,
    // kept below reflecting all light.
    materials[m.name] = m.colour.map((c, i) => c > 0
      ? Math.min(+factor.value * picked[i] / c, 0.99 / c, 2) : +factor.value);
  }
  return { lights, materials };
}

function setup(s) {
  const mode = s.spectral ? 'spectral' : 'RGB';
  $('scene').textContent = `${s.integrator}, ${mode}, ${s.width}×${s.height}`;
  $('reference-controls').hidden = !s.reference;
  if (s.reference) {
    fetchImage('reference').then((r) => { studio.reference = r; draw(); });
  }
  if (s.frames) {
    const [first, last] = s.frames;
    const input = $('frame');
    Object.assign(input, { min: first, max: last, value: s.frame ?? first });
    $('frame-value').textContent = input.value;
    $('animation').hidden = false;
    document.querySelector('#kind option[value="retrace"]').hidden = false;
    input.addEventListener('input', () => {
      $('frame-value').textContent = input.value;
      queue('frame', () => ({ frame: +input.value }));
    });
  }
  if (s.integrator === 'network' && (s.lights.length || s.materials.length)) {
    $('relight').hidden = false;
    const send = () => queue('relight', () => relightBody(s));
    for (const l of s.lights) {
      const strength = Math.max(...l.factor);
      const label = `light ${l.name}`;
      lightInputs[l.name] = {
        strength: slider($('lights'), label, strength, 4, send),
        colour: colourInput($('lights'), label, l.factor.map((k) => strength > 0 ? k / strength : 1),
                            send, l.factor.some((k) => k !== strength)),
      };
    }
    for (const m of s.materials) {
      const top = m.colour ? 0.99 / Math.max(...m.colour) : 1;
      const label = `material ${m.name}`;
      const factor = Math.max(...m.factor);
      materialInputs[m.name] = {
        factor: slider($('materials'), label, factor, Math.floor(Math.min(top, 2) * 100) / 100, send),
        // The colour shown is the material's at factor 1: picking it again changes nothing.
        colour: colourInput($('materials'), label, m.colour.map((c, i) => c * m.factor[i] / (factor || 1)),
                            send, m.factor.some((k) => k !== factor)),
      };
    }
  }
}

// ---- commands: at most one in flight per kind, the latest wins ------------------------

const inFlight = {}, latest = {};
function queue(kind, body) {
  latest[kind] = body;
  if (inFlight[kind]) return;
  const next = latest[kind];
  latest[kind] = null;
  inFlight[kind] = true;
  post(`/api/${kind}`, next())
    .catch(showError)
    .finally(() => { inFlight[kind] = false; if (latest[kind]) queue(kind, latest[kind]); });
}

// ---- camera: orbit, pan, zoom -----------------------------------------------------------

let camera = null, dragging = null;
const sub = (a, b) => a.map((v, i) => v - b[i]);
const add = (a, b) => a.map((v, i) => v + b[i]);
const mul = (a, k) => a.map((v) => v * k);
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => mul(a, 1 / Math.hypot(...a));
// Rodrigues: `v` turned by `angle` about the unit axis `k`.
const rotate = (v, k, angle) => {
  const c = Math.cos(angle), s = Math.sin(angle);
  return add(add(mul(v, c), mul(cross(k, v), s)), mul(k, dot(k, v) * (1 - c)));
};

function orbit(start, dx, dy) {
  const up = norm(start.up);
  let offset = sub(start.position, start.look_at);
  offset = rotate(offset, up, -dx * 0.01);
  const right = norm(cross(mul(offset, -1), up));
  const turned = rotate(offset, right, -dy * 0.01);
  // Never over the pole: the view would flip.
  const cosUp = dot(norm(turned), up);
  if (Math.abs(cosUp) < 0.995) offset = turned;
  return { ...start, position: add(start.look_at, offset) };
}

function pan(start, dx, dy) {
  const canvas = $('canvas');
  const forward = sub(start.look_at, start.position);
  const distance = Math.hypot(...forward);
  const right = norm(cross(forward, start.up));
  const up = norm(cross(right, forward));
  const perPixel = 2 * distance * Math.tan(start.fov * Math.PI / 360) /
    Math.min(canvas.clientWidth, canvas.clientHeight || canvas.clientWidth);
  const move = add(mul(right, -dx * perPixel), mul(up, dy * perPixel));
  return { ...start, position: add(start.position, move), look_at: add(start.look_at, move) };
}

function zoom(start, factor) {
  const offset = sub(start.position, start.look_at);
  return { ...start, position: add(start.look_at, mul(offset, factor)) };
}

// The first command of a drag or of a burst of wheel turns starts a step of the server's
// view history; the rest continue it, so that one "Undo move" undoes the whole gesture.
let stepStarts = false, lastWheel = -Infinity;
function sendCamera(c, startsStep) {
  camera = c;
  if (startsStep) stepStarts = true;
  queue('camera', () => {
    const body = { position: c.position, look_at: c.look_at, up: c.up, fov: c.fov,
                   continues: !stepStarts };
    stepStarts = false;
    return body;
  });
}

const canvas = $('canvas');
canvas.addEventListener('contextmenu', (e) => e.preventDefault());
canvas.addEventListener('pointerdown', (e) => {
  if (!camera) return;
  canvas.setPointerCapture?.(e.pointerId);
  dragging = { x: e.clientX, y: e.clientY, camera, pan: e.button !== 0 || e.shiftKey };
});
canvas.addEventListener('pointermove', (e) => {
  if (!dragging) return;
  const dx = e.clientX - dragging.x, dy = e.clientY - dragging.y;
  if (dx === 0 && dy === 0) return;
  const start = dragging.camera;
  sendCamera(dragging.pan ? pan(start, dx, dy) : orbit(start, dx, dy), !dragging.moved);
  dragging.moved = true;
});
const release = () => { dragging = null; };
canvas.addEventListener('pointerup', release);
canvas.addEventListener('pointercancel', release);
canvas.addEventListener('wheel', (e) => {
  e.preventDefault();
  if (!camera) return;
  sendCamera(zoom(camera, Math.exp(Math.max(-200, Math.min(200, e.deltaY)) * 0.002)),
             e.timeStamp - lastWheel > 500);
  lastWheel = e.timeStamp;
}, { passive: false });
// A way back from a view that left the scene: the camera before the last move, or the
// scene file's.
for (const [id, to] of [['undo-view', 'previous'], ['reset-view', 'scene']]) {
  $(id).addEventListener('click', () => post('/api/view', { to }).catch(showError));
}

// ---- controls -----------------------------------------------------------------------

$('exposure').addEventListener('input', () => {
  $('exposure-value').textContent = (+$('exposure').value).toFixed(1);
  draw();
});
for (const id of ['tone', 'split', 'split-at']) $(id).addEventListener('input', draw);
$('kind').addEventListener('change', () => { studio.image = null; refresh(); });

async function save(format) {
  try {
    const r = await post('/api/save', { format, exposure: +$('exposure').value });
    $('saved').textContent = `saved ${r.file}`;
  } catch (e) {
    $('saved').textContent = `not saved: ${e.message}`;
  }
}
$('save-exr').addEventListener('click', () => save('exr'));
$('save-png').addEventListener('click', () => save('png'));
$('copy-camera').addEventListener('click', async () => {
  const text = await (await fetch(url('/api/camera.toml'))).text();
  const area = $('camera-toml');
  area.value = text;
  area.hidden = false;
  area.select();
  try { await navigator.clipboard.writeText(text); $('saved').textContent = 'camera copied'; }
  catch { $('saved').textContent = 'select the text to copy the camera'; }
});

// ---- the events stream ----------------------------------------------------------------

const events = new EventSource(url('/api/events'));
events.onmessage = (e) => onState(JSON.parse(e.data));
events.onerror = () => { $('status').textContent = 'disconnected: retrying…'; };
