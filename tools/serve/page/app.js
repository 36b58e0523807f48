/* app.js: the `hdnet serve` page (docs/serve.md). A photo is uploaded once; the server finds and
 * decomposes its faces and sends maps at the photo's size (the photo, the predicted normals, and
 * the render's weight and skin) and each face's estimated light and landmarks. While
 * the light is dragged the page relights on its own, per pixel, by the rule of docs/usage.md
 * (relightInPage):
 *     out = I * exp(w * (log r + t)),   r = (max(s(N, l), 0) + g) / (max(s(N, l_face), 0) + g)
 * with s the SH shading of docs/conventions.md (both with the shadows the face casts, marched over
 * the server's depth map of each face's posed mesh), g the guard, w the server's weight (the feather
 * inside the mesh's edge, the forehead grown to the hairline with its outward fade), the eyes,
 * mouth and brows and the pixels beyond the mesh taking log r filled from the skin's (push-pull,
 * as the render) and blurred as the render's, and t the offset that keeps the
 * face's mean brightness. With the background relit (`--background relight`) it takes the server's
 * maps of that mode (the body's weights and normals) and then relights the wall, one factor per
 * channel, where the people map leaves it (relightWall). "Render" asks the server for its exact
 * result (`hdnet relight`).
 * Nothing is loaded from anywhere but the server. */
'use strict';
(() => {
  // ---------------------------------------------------------------- SH lighting (docs/conventions.md)
  const C0 = 0.8862269254527579, C1 = 1.023326707946488, C2 = 0.8580855308097834;
  const C3 = 0.2477079561003757, C4 = 0.4290427654048917;
  const BAND_FACTOR = [Math.PI, 2 * Math.PI / 3, 2 * Math.PI / 3, 2 * Math.PI / 3,
    Math.PI / 4, Math.PI / 4, Math.PI / 4, Math.PI / 4, Math.PI / 4];

  // The basis b_k(n) of a camera-frame normal: DPR's frame X = x, Y = -z, Z = y.
  function basis(x, y, z) {
    const X = x, Y = -z, Z = y;
    return [C0, C1 * Y, C1 * Z, C1 * X, C2 * Y * X, C2 * Y * Z, C3 * (3 * Z * Z - 1), C2 * X * Z, C4 * (X * X - Y * Y)];
  }
  // s(n) = sum_k l_k b_k(n), written out (the inner loop of the preview).
  function shade(l, x, y, z) {
    const X = x, Y = -z, Z = y;
    return l[0] * C0 + C1 * (l[1] * Y + l[2] * Z + l[3] * X) + C2 * (l[4] * Y * X + l[5] * Y * Z + l[7] * X * Z) +
      l[6] * C3 * (3 * Z * Z - 1) + l[8] * C4 * (X * X - Y * Y);
  }
  // hd_light_from_direction: intensity * 16/17 * Y_k(d), plus ambient / c0 in l_0.
  function lightFromDirection(azDeg, elDeg, intensity, ambient) {
    const az = azDeg * Math.PI / 180, el = elDeg * Math.PI / 180;
    const b = basis(Math.cos(el) * Math.sin(az), Math.sin(el), Math.cos(el) * Math.cos(az));
    const l = b.map((v, k) => intensity * (16 / 17) * v / BAND_FACTOR[k]);
    l[0] += ambient / C0;
    return l;
  }
  // The direction a light comes from (band 1: l1, l2, l3 go with -z, y, x).
  function directionOf(l) {
    const x = l[3], y = l[2], z = -l[1], n = Math.hypot(x, y, z);
    if (!(n > 0)) return { azimuth: 0, elevation: 0 };
    return { azimuth: Math.atan2(x, z) * 180 / Math.PI, elevation: Math.asin(y / n) * 180 / Math.PI };
  }

  // ---------------------------------------------------------------- state
  const $ = (id) => document.getElementById(id);
  const ui = {
    status: $('status'), drop: $('drop'), file: $('file'), view: $('view'), photo: $('photo'), overlay: $('overlay'),
    showing: $('showing'), sphere: $('sphere'), direction: $('direction'), intensity: $('intensity'),
    intensityValue: $('intensity-value'), ambient: $('ambient'), ambientValue: $('ambient-value'), keep: $('keep'),
    presets: $('presets'), background: $('background'), backgroundRelight: $('background-relight'), render: $('render'), before: $('before'), delight: $('delight'), ref: $('ref'),
    transferLabel: $('transfer-label'), download: $('download'), downloadLight: $('download-light'), marks: $('marks'),
  };
  const state = {
    photo: null,      // the upload's JSON (id, size, faces, maps)
    maps: null,       // the decoded maps, over the pixels the render may change only (the background kept)
    mapsBody: null,   // the same with the background relit (the body too, and the wall), or null
    presets: [],
    light: { kind: 'direction', azimuth: 0, elevation: 0, intensity: 1.5, ambient: 0.5, preset: -1, coeffs: null, ref: null },
    view: 'preview',  // 'preview' (in the page), 'server' (a render), 'before' (the photo as uploaded)
    result: null,     // { url, name, what } of the last server answer
    previews: 0,      // frames relit in the page (for tests)
    busy: false,
  };
  window.hdnet = { state, lightFromDirection, shade, relight: () => relightInPage() };

  function say(text, error) {
    ui.status.textContent = text;
    ui.status.classList.toggle('error', !!error);
  }

  async function failure(response) {
    try {
      const j = await response.json();
      return j.error || response.statusText;
    } catch (e) {
      return response.status + ' ' + response.statusText;
    }
  }

  // ---------------------------------------------------------------- the light
  function currentLight() {
    const L = state.light;
    if (L.kind === 'preset' || L.kind === 'coeffs') return L.coeffs;
    return lightFromDirection(L.azimuth, L.elevation, L.intensity, L.ambient);
  }

  function lightChanged() {
    const L = state.light;
    ui.direction.textContent = (L.kind === 'coeffs' ? 'transferred: ' : L.kind === 'preset' ? 'preset ' + L.preset + ': ' : '') +
      'azimuth ' + L.azimuth.toFixed(0) + '\u00b0, elevation ' + L.elevation.toFixed(0) + '\u00b0';
    ui.sphere.setAttribute('aria-valuetext', ui.direction.textContent);
    ui.intensityValue.textContent = L.intensity.toFixed(2);
    ui.ambientValue.textContent = L.ambient.toFixed(2);
    for (const b of ui.presets.querySelectorAll('button'))
      b.setAttribute('aria-pressed', String(L.kind === 'preset' && +b.dataset.preset === L.preset));
    let href;
    if (L.kind === 'preset') href = '/api/light.txt?preset=' + L.preset;
    else if (L.kind === 'coeffs') href = '/api/photos/' + L.ref + '/light.txt';
    else href = '/api/light.txt?azimuth=' + L.azimuth.toFixed(2) + '&elevation=' + L.elevation.toFixed(2) +
      '&intensity=' + L.intensity + '&ambient=' + L.ambient;
    ui.downloadLight.href = href;
    drawSphere();
    if (state.maps) {
      state.view = 'preview';
      setBefore(false);
      schedule();
    }
  }

  function setDirection(azimuth, elevation) {
    const L = state.light;
    if (L.kind !== 'direction') {
      L.kind = 'direction';
      L.preset = -1;
    }
    L.azimuth = ((azimuth + 540) % 360) - 180;
    L.elevation = Math.max(-90, Math.min(90, elevation));
    lightChanged();
  }

  // ---------------------------------------------------------------- the sphere
  const sphereCtx = ui.sphere.getContext('2d');
  const sphereImage = sphereCtx.createImageData(ui.sphere.width, ui.sphere.height);
  const R = ui.sphere.width / 2 - 6, CX = ui.sphere.width / 2, CY = ui.sphere.height / 2;

  function drawSphere() {
    const l = currentLight(), d = sphereImage.data, W = ui.sphere.width, H = ui.sphere.height;
    for (let y = 0; y < H; y++)
      for (let x = 0; x < W; x++) {
        const u = (x + 0.5 - CX) / R, v = -(y + 0.5 - CY) / R, r2 = u * u + v * v, i = 4 * (y * W + x);
        if (r2 > 1) {
          d[i] = d[i + 1] = d[i + 2] = 0;
          d[i + 3] = 0;
          continue;
        }
        const s = Math.max(0, Math.min(1, shade(l, u, v, Math.sqrt(1 - r2)) / 2)) * 255;
        d[i] = d[i + 1] = d[i + 2] = s;
        d[i + 3] = 255;
      }
    sphereCtx.putImageData(sphereImage, 0, 0);
    const dir = state.light.kind === 'direction' ? state.light : directionOf(l);
    const az = dir.azimuth * Math.PI / 180, el = dir.elevation * Math.PI / 180;
    const px = CX + Math.cos(el) * Math.sin(az) * R, py = CY - Math.sin(el) * R, front = Math.cos(el) * Math.cos(az) >= 0;
    sphereCtx.beginPath();
    sphereCtx.arc(px, py, 6, 0, 2 * Math.PI);
    sphereCtx.lineWidth = 2;
    sphereCtx.strokeStyle = '#f0b44c';
    if (front) {
      sphereCtx.fillStyle = '#f0b44c';
      sphereCtx.fill();
    }
    sphereCtx.stroke();
  }

  // A pointer at canvas position (x, y) points at the sphere's normal there; off the sphere, at its rim.
  function pointAt(event) {
    const rect = ui.sphere.getBoundingClientRect();
    const x = (event.clientX - rect.left) * ui.sphere.width / rect.width, y = (event.clientY - rect.top) * ui.sphere.height / rect.height;
    let u = (x - CX) / R, v = -(y - CY) / R;
    const r = Math.hypot(u, v);
    if (r > 1) {
      u /= r;
      v /= r;
    }
    const z = Math.sqrt(Math.max(0, 1 - u * u - v * v));
    setDirection(Math.atan2(u, z) * 180 / Math.PI, Math.asin(Math.max(-1, Math.min(1, v))) * 180 / Math.PI);
  }
  ui.sphere.addEventListener('pointerdown', (e) => {
    ui.sphere.setPointerCapture(e.pointerId);
    ui.sphere.focus();
    pointAt(e);
  });
  ui.sphere.addEventListener('pointermove', (e) => {
    if (ui.sphere.hasPointerCapture(e.pointerId)) pointAt(e);
  });
  ui.sphere.addEventListener('keydown', (e) => {
    const step = e.shiftKey ? 15 : 5, L = state.light, dir = L.kind === 'direction' ? L : directionOf(currentLight());
    const moves = { ArrowLeft: [-step, 0], ArrowRight: [step, 0], ArrowUp: [0, step], ArrowDown: [0, -step] };
    if (moves[e.key]) setDirection(dir.azimuth + moves[e.key][0], dir.elevation + moves[e.key][1]);
    else if (e.key === 'Home') setDirection(0, 0);
    else if (e.key === 'Enter') render();
    else return;
    e.preventDefault();
  });

  ui.intensity.addEventListener('input', () => {
    fromPresetToDirection();
    state.light.intensity = +ui.intensity.value;
    lightChanged();
  });
  ui.ambient.addEventListener('input', () => {
    fromPresetToDirection();
    state.light.ambient = +ui.ambient.value;
    lightChanged();
  });
  ui.keep.addEventListener('change', () => lightChanged());
  ui.background.addEventListener('change', () => lightChanged());
  // The background mode of the preview and of the server's renders: 'keep' or 'relight'.
  function background() {
    return state.mapsBody && ui.backgroundRelight.checked ? 'relight' : 'keep';
  }
  // A slider moved under a preset or a transferred light: go on from its direction.
  function fromPresetToDirection() {
    const L = state.light;
    if (L.kind === 'direction') return;
    const d = directionOf(currentLight());
    L.kind = 'direction';
    L.preset = -1;
    L.azimuth = d.azimuth;
    L.elevation = d.elevation;
  }

  async function loadPresets() {
    const r = await fetch('/api/presets');
    if (!r.ok) throw new Error(await failure(r));
    const j = await r.json();
    state.presets = j.presets;
    for (const p of j.presets) {
      const b = document.createElement('button');
      b.textContent = String(p.preset);
      b.dataset.preset = p.preset;
      b.title = 'preset ' + p.preset + ': azimuth ' + p.azimuth.toFixed(0) + '\u00b0, elevation ' + p.elevation.toFixed(0) + '\u00b0';
      b.setAttribute('aria-label', b.title);
      b.setAttribute('aria-pressed', 'false');
      b.addEventListener('click', () => {
        const L = state.light;
        Object.assign(L, { kind: 'preset', preset: p.preset, coeffs: p.light, azimuth: p.azimuth, elevation: p.elevation,
          intensity: j.default_intensity, ambient: j.default_ambient });
        ui.intensity.value = L.intensity;
        ui.ambient.value = L.ambient;
        lightChanged();
      });
      ui.presets.appendChild(b);
    }
  }

  // ---------------------------------------------------------------- the maps and the preview
  const photoCtx = ui.photo.getContext('2d');

  async function mapPixels(url) {
    const r = await fetch(url);
    if (!r.ok) throw new Error(await failure(r));
    const bitmap = await createImageBitmap(await r.blob(), { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
    const c = document.createElement('canvas');
    c.width = bitmap.width;
    c.height = bitmap.height;
    const ctx = c.getContext('2d', { willReadFrequently: true });
    ctx.drawImage(bitmap, 0, 0);
    return ctx.getImageData(0, 0, c.width, c.height);
  }

  // The rule's constants (src/apply/rule.c, apply.h): the guard, the blur of log r (a share of the
  // texture's side) and the eye distance in the texture (models/canonical_face_model.obj's UV
  // layout), which turns it into photo pixels. The weights and the skin are the server's maps.
  const RATIO_GUARD = 0.01, RATIO_BLUR = 0.012, EYE_DISTANCE_UV = 0.3076;
  // cast shadows (src/apply/rule.c, src/mesh/cast_shadow.c): the softness and the first step of the
  // march in cm of the face mesh, the least share of a shading a shadow leaves
  const SHADOW_SOFTNESS = 0.3, SHADOW_START = 0.16, SHADOW_FLOOR = 0.4;

  // The depth map (the server's "depth": each face's posed mesh, photo pixels toward the camera;
  // -Infinity off the faces) and its highest value.
  function decodeDepth(depth, code) {
    const n = depth.width * depth.height, z = new Float32Array(n);
    let top = -Infinity;
    for (let p = 0; p < n; p++) {
      const o = 4 * p;
      z[p] = depth.data[o + 2] === 255 ? code.z0 + (256 * depth.data[o] + depth.data[o + 1] - 1) * code.step : -Infinity;
      if (z[p] > top) top = z[p];
    }
    return { W: depth.width, H: depth.height, z, top };
  }

  // hd_light_distant_part: the distant light of a light's first band, its direction d (camera frame)
  // and the light of lightFromDirection along d with no ambient; null for a light with no first band.
  const UNIT_BAND = Math.hypot(...lightFromDirection(0, 0, 1, 0).slice(1, 4));
  function distantPart(l) {
    const x = l[3], y = l[2], z = -l[1], len = Math.hypot(x, y, z);
    if (!(len > 1e-12)) return null;
    const d = [x / len, y / len, z / len];
    return { d, light: lightFromDirection(Math.atan2(d[0], d[2]) * 180 / Math.PI, Math.asin(d[1]) * 180 / Math.PI, len / UNIT_BAND, 0) };
  }

  // hd_mesh_cast_shadow_uv in the photo: how much of the light from d the face's point at pixel p
  // (depth z) sees, marching one pixel at a time over the depth map toward the light (scale: the
  // face's photo pixels per cm); 1 lit, 0 in full shadow.
  function visibility(D, p, d, scale) {
    const dxy = Math.hypot(d[0], d[1]);
    if (dxy < 1e-4) return 1;
    const x0 = p % D.W, y0 = (p - x0) / D.W, z0 = D.z[p], sx = d[0] / dxy, sy = -d[1] / dxy, sz = d[2] / dxy;
    const soft = SHADOW_SOFTNESS * scale;
    let depth = 0;
    for (let s = SHADOW_START * scale; ; s += 1) {
      const zr = z0 + s * sz;
      if (zr > D.top && sz >= 0) break;
      const x = Math.round(x0 + s * sx), y = Math.round(y0 + s * sy);
      if (x < 0 || y < 0 || x >= D.W || y >= D.H) break;
      const zs = D.z[y * D.W + x];
      if (zs - zr > depth) depth = zs - zr;
    }
    const t = Math.min(1, depth / soft);
    return 1 - t * t * (3 - 2 * t);
  }

  // The shading of light l at normal n with its cast shadows: s' = max(s - (1 - V) max(s_d, 0),
  // SHADOW_FLOOR s), part the light's distantPart (null: none).
  function shadowed(s, l, part, V, x, y, z) {
    if (!part || V >= 1) return s;
    const lit = s - (1 - V) * Math.max(shade(part.light, x, y, z), 0);
    return Math.max(lit, SHADOW_FLOOR * s);
  }
  // The heads' two planes are blurred by box passes past a radius of 4 pixels (a face over about 20
  // pixels between the eyes): on the test photo as close to the render as the exact Gaussian (the
  // head's blur is over 0.06 eye distances, smoother than what it blurs), at a third of the cost.
  const HEAD_BOXES_PAST = 4;
  const RIGHT_EYE = [33, 7, 163, 144, 145, 153, 154, 155, 133, 173, 157, 158, 159, 160, 161, 246];
  const LEFT_EYE = [263, 249, 390, 373, 374, 380, 381, 382, 362, 398, 384, 385, 386, 387, 388, 466];

  function eyeDistance(f) {
    const c = [RIGHT_EYE, LEFT_EYE].map((e) => e.reduce((a, i) => [a[0] + f.landmarks[i][0] / e.length,
      a[1] + f.landmarks[i][1] / e.length], [0, 0]));
    return Math.hypot(c[1][0] - c[0][0], c[1][1] - c[0][1]);
  }

  // Push-pull filling (hd_field_fill, src/apply/fields.c), over a pyramid kept from one frame to the
  // next: level 0 is the fill window; each level halves it. fillField fills lv[0].v where lv[0].wt < 1
  // from the values around (wt 1 known, 0 unknown), as the render fills log r beyond the mesh.
  function pyramid(w, h) {
    const lv = [];
    for (;;) {
      lv.push({ w, h, v: new Float32Array(w * h), wt: new Float32Array(w * h) });
      if (w === 1 && h === 1) return lv;
      w = (w + 1) >> 1, h = (h + 1) >> 1;
    }
  }
  function fillLevel(lv, k) {
    const { w, h, v, wt } = lv[k];
    let done = true;
    for (let p = 0; p < w * h && done; p++) done = wt[p] >= 1;
    if (done || k + 1 === lv.length) return;
    const { w: W2, h: H2, v: cv, wt: cw } = lv[k + 1];
    cv.fill(0), cw.fill(0);
    for (let y = 0; y < h; y++) // push: 2 x 2 sums of the weighted values and weights
      for (let x = 0; x < w; x++) {
        const c = (y >> 1) * W2 + (x >> 1), p = y * w + x;
        cv[c] += v[p] * wt[p];
        cw[c] += wt[p];
      }
    for (let c = 0; c < W2 * H2; c++)
      if (cw[c] > 0) {
        cv[c] /= cw[c];
        if (cw[c] > 1) cw[c] = 1;
      }
    fillLevel(lv, k + 1);
    for (let y = 0; y < h; y++) { // pull: what a cell lacks in weight comes from the coarser level, bilinearly
      const fy = (y + 0.5) / 2 - 0.5, y0 = Math.floor(fy), ay = fy - y0;
      const r0 = Math.max(0, Math.min(H2 - 1, y0)) * W2, r1 = Math.max(0, Math.min(H2 - 1, y0 + 1)) * W2;
      for (let x = 0; x < w; x++) {
        const p = y * w + x;
        if (wt[p] >= 1) continue;
        const fx = (x + 0.5) / 2 - 0.5, x0 = Math.floor(fx), ax = fx - x0;
        const c0 = Math.max(0, Math.min(W2 - 1, x0)), c1 = Math.max(0, Math.min(W2 - 1, x0 + 1));
        const coarse = (1 - ay) * ((1 - ax) * cv[r0 + c0] + ax * cv[r0 + c1]) + ay * ((1 - ax) * cv[r1 + c0] + ax * cv[r1 + c1]);
        const a = wt[p] < 0 ? 0 : wt[p];
        v[p] = a * v[p] + (1 - a) * coarse;
        wt[p] = 1;
      }
    }
  }

  // Gaussian blur of a w x h plane in place, sd sigma pixels (hd_field_blur: separable, edges
  // clamped). Past a radius of boxesPast pixels (10: a face field's blur for a face over about 80
  // pixels between the eyes), three box passes along the rows and three along the columns whose
  // widths give sigma's variance instead, so that a frame's cost per pixel does not grow with the
  // face.
  function blur(v, w, h, sigma, tmp, boxesPast = 10) {
    if (!(sigma > 0.3)) return;
    const r = Math.ceil(3 * sigma);
    if (r > boxesPast) return blurBoxes(v, w, h, sigma, tmp);
    const k = new Float32Array(2 * r + 1), n = 2 * r + 1, line = new Float32Array(w + 2 * r);
    let sum = 0;
    for (let i = -r; i <= r; i++) sum += k[i + r] = Math.exp(-0.5 * i * i / (sigma * sigma));
    for (let i = 0; i < n; i++) k[i] /= sum;
    for (let y = 0; y < h; y++) { // the rows, each copied with its ends extended by r
      const o = y * w;
      line.fill(v[o], 0, r);
      line.set(v.subarray(o, o + w), r);
      line.fill(v[o + w - 1], r + w);
      for (let x = 0; x < w; x++) {
        let acc = 0;
        for (let i = 0; i < n; i++) acc += k[i] * line[x + i];
        tmp[o + x] = acc;
      }
    }
    for (let y = 0; y < h; y++) { // the columns, a row of taps at a time
      const o = y * w;
      for (let i = 0; i < n; i++) {
        const s = Math.min(h - 1, Math.max(0, y + i - r)) * w, ki = k[i];
        if (i === 0) for (let x = 0; x < w; x++) v[o + x] = ki * tmp[s + x];
        else for (let x = 0; x < w; x++) v[o + x] += ki * tmp[s + x];
      }
    }
  }
  function blurBoxes(v, w, h, sigma, tmp) {
    let wl = Math.floor(Math.sqrt(4 * sigma * sigma + 1)); // odd widths wl and wl + 2 (Wells, 1986)
    if (wl % 2 === 0) wl--;
    const m = Math.round((12 * sigma * sigma - 3 * wl * wl - 12 * wl - 9) / (-4 * wl - 4));
    for (let i = 0; i < 3; i++) {
      const r = ((i < m ? wl : wl + 2) - 1) / 2;
      boxPass(v, tmp, w, h, r, w, 1);
      boxPass(tmp, v, h, w, r, 1, w);
    }
  }
  // out = the mean of src over 2r + 1 samples along each of `lines` lines of n samples (step apart;
  // lines lineStep apart), the ends clamped.
  function boxPass(src, out, n, lines, r, lineStep, step) {
    const norm = 1 / (2 * r + 1);
    for (let l = 0; l < lines; l++) {
      const o = l * lineStep;
      let acc = 0;
      for (let i = -r; i <= r; i++) acc += src[o + Math.min(n - 1, Math.max(0, i)) * step];
      for (let i = 0; i < n; i++) {
        out[o + i * step] = acc * norm;
        acc += src[o + Math.min(n - 1, i + r + 1) * step] - src[o + Math.max(0, i - r) * step];
      }
    }
  }

  // Keeps, for each pixel the render may change (the server's weight map above 0: the render's
  // final weight, over the whole heads), what the rule needs: I, the weight w, and on the faces'
  // skin (the server's skin map: the meshes outside the eyes, mouth and brows) N and the source
  // shading s(N, l_face) of its face, the last whose landmarks' extent, grown by an eye distance,
  // holds it; the rest (those regions, the forehead beyond the mesh, the heads) takes log r filled
  // from the skin's over a window around the faces and their heads. Then each face's head
  // (prepareHead), in the order the render takes them. With the background relit, level is the
  // server's body_level map (the weight without the body's share, whose luminance the brightness
  // keeps: hd_head_level) and people its people map (the wall takes 1 - people of its change);
  // both null with the background kept.
  function prepareMaps(photo, normal, weight, skin, head, faces, level, people, depth) {
    const W = photo.width, H = photo.height, n = W * H;
    const parts = faces.map((f) => distantPart(f.light));
    const owner = new Int16Array(n).fill(-1);
    faces.forEach((f, k) => {
      const xs = f.landmarks.map((q) => q[0]), ys = f.landmarks.map((q) => q[1]), e = Math.ceil(eyeDistance(f)) + 2;
      const x0 = Math.max(0, Math.floor(Math.min(...xs)) - e), x1 = Math.min(W, Math.ceil(Math.max(...xs)) + e);
      const y0 = Math.max(0, Math.floor(Math.min(...ys)) - e), y1 = Math.min(H, Math.ceil(Math.max(...ys)) + e);
      for (let y = y0; y < y1; y++) for (let x = x0; x < x1; x++) owner[y * W + x] = k;
    });
    let count = 0, bx0 = W, by0 = H, bx1 = 0, by1 = 0;
    for (let p = 0; p < n; p++)
      if (weight.data[4 * p] > 0) {
        count++;
        const x = p % W, y = (p - x) / W;
        bx0 = Math.min(bx0, x), bx1 = Math.max(bx1, x + 1), by0 = Math.min(by0, y), by1 = Math.max(by1, y + 1);
      }
    const heads = faces.filter((f) => f.head && count);
    for (const f of heads) { // the face field is read over the heads' windows too
      const [x0, y0, w, h] = f.head.window;
      bx0 = Math.min(bx0, x0), bx1 = Math.max(bx1, x0 + w), by0 = Math.min(by0, y0), by1 = Math.max(by1, y0 + h);
    }
    // the fill window: the changed pixels' and the heads' extent, its corner on a multiple of 64
    // pixels as the render's pyramid over the whole photo has its cells
    const wx0 = bx0 & ~63, wy0 = by0 & ~63, wx1 = Math.min(W, (bx1 + 63) & ~63), wy1 = Math.min(H, (by1 + 63) & ~63);
    const ww = Math.max(1, wx1 - wx0), wh = Math.max(1, wy1 - wy0);
    const m = { W, H, n: count, base: photo, weight, out: new ImageData(new Uint8ClampedArray(photo.data), W, H),
      px: new Int32Array(count), rgb: new Float32Array(3 * count), w: new Float32Array(count),
      level: new Uint8Array(count), lq: new Uint8Array(count), top: new Float32Array(count),
      wLum: new Float32Array(count), goal: 0,
      nrm: new Float32Array(3 * count), src: new Float32Array(count), guard: new Float32Array(count),
      face: new Int16Array(count), skin: new Uint8Array(count), cell: new Int32Array(count), depth,
      scale: faces.map((f) => f.scale), shadow: new Uint8Array(count),
      faces: faces.length, fill: count ? pyramid(ww, wh) : null, known: new Float32Array(count ? ww * wh : 0),
      blurTmp: new Float32Array(count ? ww * wh : 0),
      sigma: RATIO_BLUR / EYE_DISTANCE_UV * Math.min(...faces.map(eyeDistance)),
      heads: heads.map((f) => prepareHead(f, head, W, wx0, wy0, ww)) };
    const headOf = new Int16Array(count ? n : 0).fill(-1); // the last head whose window holds the pixel
    m.heads.forEach((hd, k) => {
      for (let y = hd.y0; y < hd.y0 + hd.h; y++) headOf.fill(k, y * W + hd.x0, y * W + hd.x0 + hd.w);
    });
    const sum = new Float64Array(faces.length), num = new Float64Array(faces.length);
    let j = 0;
    for (let p = 0; p < n; p++) {
      if (!(weight.data[4 * p] > 0)) continue;
      const k = owner[p], px = p % W, py = (p - px) / W;
      m.px[j] = p;
      m.cell[j] = (py - wy0) * ww + (px - wx0);
      for (let c = 0; c < 3; c++) m.rgb[3 * j + c] = photo.data[4 * p + c] / 255;
      m.level[j] = weight.data[4 * p];
      m.w[j] = m.level[j] / 255;
      m.top[j] = Math.max(m.rgb[3 * j], m.rgb[3 * j + 1], m.rgb[3 * j + 2]);
      m.lq[j] = level ? level.data[4 * p] : m.level[j];
      m.wLum[j] = m.lq[j] / 255 * (0.2126 * m.rgb[3 * j] + 0.7152 * m.rgb[3 * j + 1] + 0.0722 * m.rgb[3 * j + 2]);
      m.goal += m.wLum[j];
      m.face[j] = k;
      if (k >= 0 && skin.data[4 * p] > 0) {
        const [x, y, z] = unitNormal(normal.data, 4 * p);
        m.skin[j] = 1;
        m.known[m.cell[j]] = 1;
        m.nrm[3 * j] = x, m.nrm[3 * j + 1] = y, m.nrm[3 * j + 2] = z;
        m.src[j] = Math.max(shade(faces[k].light, x, y, z), 0);
        sum[k] += m.src[j], num[k]++;
        // the face's own light casts its shadows too (the guard is of the shading without them)
        m.shadow[j] = depth && depth.z[p] > -Infinity ? 1 : 0;
        if (m.shadow[j] && parts[k])
          m.src[j] = shadowed(m.src[j], faces[k].light, parts[k], visibility(depth, p, parts[k].d, faces[k].scale), x, y, z);
      }
      if (headOf[p] >= 0) {
        const hd = m.heads[headOf[p]];
        hd.ownPixel.push(j), hd.ownIndex.push((py - hd.y0) * hd.w + (px - hd.x0));
      }
      j++;
    }
    for (let i = 0; i < count; i++) {
      const k = m.face[i];
      if (k >= 0) m.guard[i] = RATIO_GUARD * (num[k] > 0 && sum[k] > 0 ? sum[k] / num[k] : 1);
    }
    for (const hd of m.heads) hd.ownPixel = Int32Array.from(hd.ownPixel), hd.ownIndex = Int32Array.from(hd.ownIndex);
    if (people) { // the wall: each pixel's share 1 - people (one of 256 levels), and its light from the first face's
      m.people = new Uint8Array(n);
      for (let p = 0; p < n; p++) m.people[p] = people.data[4 * p];
      m.wallLight = faces[0].light;
    }
    return m;
  }

  // The unit normal an 8-bit normal map holds at byte offset o ((n + 1) / 2).
  function unitNormal(data, o) {
    const x = data[o] / 127.5 - 1, y = data[o + 1] / 127.5 - 1, z = data[o + 2] / 127.5 - 1, len = Math.hypot(x, y, z) || 1;
    return [x / len, y / len, z / len];
  }

  // Face f's head (src/apply/head.c, hd_head; the server's head_* maps over its window x0, y0, w, h):
  // the blended normals and the proxy's with their shading under the face's own light, how much of
  // the face's own field holds (mesh; known where it is 1), the skin's and the hair's weights and
  // how near the skin, each window pixel's cell in the face field's window, the planes a frame
  // works in, and the changed pixels whose rule this head gives (the maps hold the last face's head
  // where windows overlap).
  function prepareHead(f, head, W, wx0, wy0, ww) {
    const [x0, y0, w, h] = f.head.window, N = w * h;
    const hd = { x0, y0, w, h, N, g: f.head.guard, sigma: f.head.blur,
      nrm: new Float32Array(3 * N), prx: new Float32Array(3 * N), srcN: new Float32Array(N), srcP: new Float32Array(N),
      mesh: new Float32Array(N), known: new Float32Array(N), ws: new Float32Array(N), wh: new Float32Array(N),
      near: new Float32Array(N), cell: new Int32Array(N), skinLr: new Float32Array(N), hairLr: new Float32Array(N),
      tmp: new Float32Array(N), fill: pyramid(w, h), ownPixel: [], ownIndex: [] };
    for (let y = 0; y < h; y++)
      for (let x = 0; x < w; x++) {
        const i = y * w + x, o = 4 * ((y + y0) * W + x + x0);
        const a = unitNormal(head.normal.data, o), b = unitNormal(head.proxy.data, o);
        hd.nrm.set(a, 3 * i), hd.prx.set(b, 3 * i);
        hd.srcN[i] = Math.max(shade(f.light, a[0], a[1], a[2]), 0);
        hd.srcP[i] = Math.max(shade(f.light, b[0], b[1], b[2]), 0);
        hd.mesh[i] = head.mesh.data[o] / 255;
        hd.known[i] = head.mesh.data[o] === 255 ? 1 : 0;
        hd.ws[i] = head.weights.data[o] / 255, hd.wh[i] = head.weights.data[o + 1] / 255;
        hd.near[i] = head.weights.data[o + 2] / 255;
        hd.cell[i] = (y + y0 - wy0) * ww + (x + x0 - wx0);
      }
    return hd;
  }

  // log((max(s(n, l), 0) + g) / (s_source + g)) over a head's window, n its normals (3 a pixel).
  function headLogRatio(l, nrm, src, g, out) {
    for (let i = 0; i < out.length; i++) {
      const t = Math.max(shade(l, nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]), 0);
      out[i] = t === src[i] ? 0 : Math.log((t + g) / (src[i] + g));
    }
  }

  // hd_head_apply for one head: the face field F (the fill window's cells) handed over, beyond the
  // mesh, to the ratio on the blended normals on the skin and on the proxy's on the hair, both
  // blurred and kept within the face field's range over the mesh; the result into L, for the
  // changed pixels the head gives the rule of, where its weights are above 0.
  function relightHead(hd, l, F, L) {
    const { N, cell, known, mesh, ws, wh, near, skinLr: s, hairLr: a } = hd;
    headLogRatio(l, hd.nrm, hd.srcN, hd.g, s);
    headLogRatio(l, hd.prx, hd.srcP, hd.g, a);
    blur(s, hd.w, hd.h, hd.sigma, hd.tmp, HEAD_BOXES_PAST);
    blur(a, hd.w, hd.h, hd.sigma, hd.tmp, HEAD_BOXES_PAST);
    let lo = Infinity, hi = -Infinity;
    for (let i = 0; i < N; i++)
      if (known[i]) {
        const v = F[cell[i]];
        if (v < lo) lo = v;
        if (v > hi) hi = v;
      }
    if (!(lo <= hi)) lo = hi = 0;
    const off = hd.fill[0];
    for (let i = 0; i < N; i++) {
      s[i] = Math.min(hi, Math.max(lo, s[i]));
      a[i] = Math.min(hi, Math.max(lo, a[i]));
      off.v[i] = known[i] ? F[cell[i]] - s[i] : 0; // the face's field minus the head's on the mesh, carried past it
      off.wt[i] = known[i];
    }
    fillLevel(hd.fill, 0);
    for (let k = 0; k < hd.ownPixel.length; k++) {
      const i = hd.ownIndex[k], sum = ws[i] + wh[i];
      if (!(sum > 0)) continue;
      const ls = s[i] + mesh[i] * off.v[i], hl = near[i] * ls + (1 - near[i]) * a[i];
      L[hd.ownPixel[k]] = Math.min(hi, Math.max(lo, (ws[i] * ls + wh[i] * hl) / sum));
    }
  }

  // The rule of docs/usage.md per pixel: out = I * exp(w * (log r + t)),
  // r = (max(s(N, l), 0) + g) / (s(N, l_face) + g) on the skin, filled from the skin's over the
  // regions and beyond the meshes (push-pull, as the render), then over each head as the render
  // (relightHead), t the one offset that keeps the w-weighted mean luminance (--keep-brightness),
  // the factor lowered for a pixel where a channel would pass 1.
  function relightInPage() {
    const m = background() === 'relight' ? state.mapsBody : state.maps, l = currentLight(), d = m.out.data;
    const L = new Float32Array(m.n), part = m.depth ? distantPart(l) : null;
    for (let j = 0; j < m.n; j++) {
      if (!m.skin[j]) continue;
      const x = m.nrm[3 * j], y = m.nrm[3 * j + 1], z = m.nrm[3 * j + 2], g = m.guard[j];
      let t = Math.max(shade(l, x, y, z), 0);
      if (part && m.shadow[j]) t = shadowed(t, l, part, visibility(m.depth, m.px[j], part.d, m.scale[m.face[j]]), x, y, z);
      L[j] = t === m.src[j] ? 0 : Math.log((t + g) / (m.src[j] + g));
    }
    if (m.fill) { // the regions and beyond the meshes: log r filled from the skin's (hd_field_fill)
      const f = m.fill[0];
      f.v.fill(0);
      f.wt.set(m.known);
      for (let j = 0; j < m.n; j++) if (m.skin[j]) f.v[m.cell[j]] = L[j];
      fillLevel(m.fill, 0);
      blur(f.v, f.w, f.h, m.sigma, m.blurTmp);
      for (let j = 0; j < m.n; j++) L[j] = f.v[m.cell[j]];
      for (const hd of m.heads) relightHead(hd, l, f.v, L);
    }
    // exp(w (L + t)) = exp(w L) exp(w t), and w is one of 256 levels: exp(w t) is a table
    const e = new Float32Array(m.n), E = new Float64Array(256), table = (t) => {
      for (let q = 0; q < 256; q++) E[q] = Math.exp(q / 255 * t);
    };
    for (let j = 0; j < m.n; j++) e[j] = Math.exp(m.w[j] * L[j]);
    // the kept brightness is the level's picture's, relit with the level's weights (hd_ratio_apply):
    // with the background relit, the body beyond the neck's reach left out (lq: the level, else w)
    const eq = new Float32Array(m.n);
    for (let j = 0; j < m.n; j++) eq[j] = m.lq[j] === m.level[j] ? e[j] : Math.exp(m.lq[j] / 255 * L[j]);
    let t = 0;
    if (ui.keep.checked && m.goal > 0)
      for (let it = 0; it < 6; it++) { // Newton on sum level lum exp(level (L + t)) = goal (level: w, or w without the body)
        let f = 0, df = 0;
        table(t);
        for (let j = 0; j < m.n; j++) {
          const v = m.wLum[j] * eq[j] * E[m.lq[j]];
          f += v;
          df += m.lq[j] / 255 * v;
        }
        if (!(df > 0)) break;
        t -= (f - m.goal) / df;
      }
    table(t);
    const wall = m.people ? relightWall(m, l, t) : null;
    for (let j = 0; j < m.n; j++) {
      const p = 4 * m.px[j], top = m.top[j];
      let k = e[j] * E[m.level[j]];
      if (top > 0 && k * top > 1) k = 1 / top;
      // (the canvas's bytes round to the nearest level, as the server's PNG does)
      if (!wall) for (let c = 0; c < 3; c++) d[p + c] = 255 * k * m.rgb[3 * j + c];
      else for (let c = 0; c < 3; c++) d[p + c] = 255 * Math.min(1, k * m.rgb[3 * j + c] * wall[m.people[m.px[j]]]);
    }
    photoCtx.putImageData(m.out, 0, 0);
    state.previews++;
    ui.showing.textContent = 'preview (in the page)';
  }

  // The wall (src/apply/backdrop.c, hd_backdrop_apply): out = I * exp(b * (log r0 + t)), clamped to 1
  // per channel, b = 1 - people, r0 the ratio of a wall facing the camera (n = (0, 0, 1)) under the
  // light l and the first face's own, with the rule's guard (a hundredth of its source shading), t
  // the faces' brightness offset. Writes every pixel the faces leave (they are written after, by
  // the caller, with the same factors) and returns the factor of each people level (256; the page's
  // lights are grey, so one for all three channels).
  function relightWall(m, l, t) {
    const s = Math.max(shade(m.wallLight, 0, 0, 1), 0), g = RATIO_GUARD * Math.max(s, 1e-6);
    const lt = Math.max(shade(l, 0, 0, 1), 0), lr = lt === s ? 0 : Math.log((lt + g) / (s + g));
    const F = new Float32Array(256);
    for (let q = 0; q < 256; q++) F[q] = lr === 0 && t === 0 ? 1 : Math.exp((1 - q / 255) * (lr + t));
    const d = m.out.data, base = m.base.data, people = m.people;
    for (let p = 0; p < m.W * m.H; p++) {
      const f = F[people[p]], o = 4 * p;
      for (let c = 0; c < 3; c++) d[o + c] = Math.min(255, base[o + c] * f);
    }
    return F;
  }

  let frame = 0;
  function schedule() {
    if (frame) return;
    frame = requestAnimationFrame(() => {
      frame = 0;
      if (state.maps && state.view === 'preview') relightInPage();
    });
  }

  function drawMarks() {
    const o = ui.overlay, ctx = o.getContext('2d');
    ctx.clearRect(0, 0, o.width, o.height);
    if (!state.photo || !ui.marks.checked) return;
    const lw = Math.max(2, o.width / 300);
    ctx.lineWidth = lw;
    ctx.strokeStyle = '#f0b44c';
    ctx.fillStyle = '#f0b44c';
    ctx.font = (6 * lw) + 'px system-ui, sans-serif';
    state.photo.faces.forEach((f, k) => {
      const [x0, y0, x1, y1] = f.box;
      ctx.strokeRect(x0, y0, x1 - x0, y1 - y0);
      ctx.fillText('face ' + k, x0, Math.max(6 * lw, y0 - lw));
      for (let i = 0; i < f.landmarks.length; i += 12) ctx.fillRect(f.landmarks[i][0] - lw / 4, f.landmarks[i][1] - lw / 4, lw / 2, lw / 2);
    });
  }
  ui.marks.addEventListener('change', drawMarks);

  // The photo shown as large as the window allows (the canvases keep the photo's own pixels).
  function fit() {
    if (!state.photo) return;
    const W = state.photo.width, H = state.photo.height;
    const room = ui.view.parentElement.clientWidth, high = window.innerHeight - ui.view.getBoundingClientRect().top - 16;
    const scale = Math.max(0.05, Math.min(room / W, Math.max(200, high) / H));
    ui.photo.style.width = Math.floor(W * scale) + 'px';
  }
  window.addEventListener('resize', fit);

  // ---------------------------------------------------------------- server calls
  function enable(on) {
    for (const b of [ui.render, ui.before, ui.delight]) b.disabled = !on;
    ui.ref.disabled = !on;
    ui.transferLabel.classList.toggle('disabled', !on);
  }

  async function uploadFile(file) {
    const type = file.type === 'image/png' || file.type === 'image/jpeg' ? file.type :
      /\.png$/i.test(file.name) ? 'image/png' : 'image/jpeg';
    const r = await fetch('/api/photos', { method: 'POST', headers: { 'Content-Type': type }, body: file });
    if (!r.ok) throw new Error(await failure(r));
    return r.json();
  }

  async function openPhoto(file) {
    if (!file || state.busy) return;
    state.busy = true;
    enable(false);
    say('Finding and decomposing the faces of ' + file.name + '\u2026');
    try {
      const j = await uploadFile(file);
      const relit = j.backgrounds.includes('relight'), body = relit ? ['body_weight', 'body_level', 'body_head_normal',
        'body_head_proxy', 'body_head_weights', 'body_head_mesh', 'people'] : [];
      const [photo, normal, weight, skin, hn, hp, hw, hm, dm, ...bm] = await Promise.all(['photo', 'normal', 'weight', 'skin',
        'head_normal', 'head_proxy', 'head_weights', 'head_mesh', 'depth', ...body].map((k) => mapPixels(j.maps[k])));
      state.photo = j;
      const depth = decodeDepth(dm, j.depth);
      state.maps = prepareMaps(photo, normal, weight, skin, { normal: hn, proxy: hp, weights: hw, mesh: hm }, j.faces, null, null,
        depth);
      // with the background relit: the body's maps, over the heads' windows with the body
      const bodyFaces = j.faces.map((f) => Object.assign({}, f, { head: f.head && Object.assign({}, f.head, { window: f.head.body_window }) }));
      state.mapsBody = relit ? prepareMaps(photo, normal, bm[0], skin, { normal: bm[2], proxy: bm[3], weights: bm[4], mesh: bm[5] },
        bodyFaces, bm[1], bm[6], depth) : null;
      ui.backgroundRelight.disabled = !relit;
      ui.background.title = relit ? '' : j.background_reason;
      if (!relit) ui.background.querySelector('input[value="keep"]').checked = true;
      for (const c of [ui.photo, ui.overlay]) {
        c.width = j.width;
        c.height = j.height;
      }
      ui.view.hidden = false;
      ui.drop.classList.add('compact');
      fit();
      drawMarks();
      // start from the light the model estimates for the first face
      const f = j.faces[0];
      Object.assign(state.light, { kind: 'direction', preset: -1, coeffs: null, azimuth: f.azimuth, elevation: f.elevation });
      enable(true);
      lightChanged();
      say(j.width + ' \u00d7 ' + j.height + ', ' + j.faces.length + (j.faces.length === 1 ? ' face' : ' faces') +
        ' (the server keeps the ' + j.max_photos + ' most recent photos). Drag the light on the sphere.');
    } catch (e) {
      say(file.name + ': ' + e.message, true);
      if (state.photo) enable(true);
    } finally {
      state.busy = false;
    }
  }

  async function showServerResult(response, what) {
    if (!response.ok) throw new Error(await failure(response));
    const blob = await response.blob();
    const bitmap = await createImageBitmap(blob, { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
    if (state.result) URL.revokeObjectURL(state.result.url);
    state.result = { url: URL.createObjectURL(blob), name: state.photo.id + '-' + what + '.png', what };
    ui.download.href = state.result.url;
    ui.download.download = state.result.name;
    ui.download.classList.remove('disabled');
    ui.download.removeAttribute('aria-disabled');
    state.view = 'server';
    setBefore(false);
    photoCtx.drawImage(bitmap, 0, 0);
    ui.showing.textContent = what + ' (the server\u2019s exact result)';
  }

  async function serverCall(what, url, init) {
    if (!state.photo || state.busy) return;
    state.busy = true;
    say(what + ': the server is rendering the whole photo\u2026');
    try {
      await showServerResult(await fetch(url, Object.assign({ method: 'POST' }, init)), what);
      say(what + ': done. Download it, or drag the light to go on.');
    } catch (e) {
      say(what + ': ' + e.message, true);
    } finally {
      state.busy = false;
    }
  }

  function render() {
    const L = state.light, id = state.photo && state.photo.id;
    if (!id) return;
    if (L.kind === 'coeffs')
      return serverCall('transfer', '/api/photos/' + id + '/transfer?ref=' + L.ref + '&background=' + background());
    const body = L.kind === 'preset' ? { preset: L.preset } :
      { azimuth: +L.azimuth.toFixed(2), elevation: +L.elevation.toFixed(2), intensity: L.intensity, ambient: L.ambient };
    body.brightness = ui.keep.checked ? 'keep' : 'free';
    body.background = background();
    return serverCall('relight', '/api/photos/' + id + '/relight',
      { headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) });
  }

  function setBefore(on) {
    ui.before.setAttribute('aria-pressed', String(on));
    if (!state.maps) return;
    if (on) {
      photoCtx.putImageData(state.maps.base, 0, 0);
      ui.showing.textContent = 'before (the photo as uploaded)';
    }
  }

  ui.render.addEventListener('click', render);
  ui.delight.addEventListener('click', () => serverCall('delight', '/api/photos/' + state.photo.id + '/delight?background=' +
    background()));
  ui.before.addEventListener('click', async () => {
    const on = ui.before.getAttribute('aria-pressed') !== 'true';
    setBefore(on);
    if (on) return;
    if (state.view === 'server' && state.result) {
      const bitmap = await createImageBitmap(await (await fetch(state.result.url)).blob(),
        { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
      photoCtx.drawImage(bitmap, 0, 0);
      ui.showing.textContent = state.result.what + ' (the server\u2019s exact result)';
    } else {
      relightInPage();
    }
  });

  ui.ref.addEventListener('change', async () => {
    const file = ui.ref.files[0];
    ui.ref.value = '';
    if (!file || !state.photo || state.busy) return;
    state.busy = true;
    say('Estimating the light of ' + file.name + '\u2026');
    let j;
    try {
      j = await uploadFile(file);
    } catch (e) {
      say(file.name + ': ' + e.message, true);
      state.busy = false;
      return;
    }
    state.busy = false;
    const f = j.faces[0];
    Object.assign(state.light, { kind: 'coeffs', preset: -1, coeffs: f.light, ref: j.id, azimuth: f.azimuth, elevation: f.elevation });
    lightChanged();
    await serverCall('transfer', '/api/photos/' + state.photo.id + '/transfer?ref=' + j.id + '&background=' + background());
  });

  // ---------------------------------------------------------------- choosing and dropping photos
  ui.file.addEventListener('change', () => {
    openPhoto(ui.file.files[0]);
    ui.file.value = '';
  });
  ui.drop.addEventListener('keydown', (e) => {
    if (e.key === 'Enter' || e.key === ' ') {
      ui.file.click();
      e.preventDefault();
    }
  });
  document.addEventListener('dragover', (e) => {
    e.preventDefault();
    ui.drop.classList.add('over');
  });
  document.addEventListener('dragleave', () => ui.drop.classList.remove('over'));
  document.addEventListener('drop', (e) => {
    e.preventDefault();
    ui.drop.classList.remove('over');
    if (e.dataTransfer.files.length) openPhoto(e.dataTransfer.files[0]);
  });

  lightChanged();
  loadPresets().catch((e) => say('presets: ' + e.message, true));
})();
