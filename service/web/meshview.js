// The WebGL2 view of the float32 mesh (GET mesh?format=f32 over GET topology, or positions alone with
// the normals made here): a drag turns it, the wheel zooms; and `drag`, the pointer-drag helper the
// render preview shares. A module of the page.

export function createMeshView(canvas) {
  const c = canvas.getContext('webgl2', { antialias: true });
  const view = { yaw: 0, pitch: 0, zoom: 1, center: [0, 0, 0], radius: 1, vertices: 0, draws: [] };
  if (!c) return { update() {}, updatePositions() {}, setTopology() {}, view, coverage: () => -1 };
  const vs = `#version 300 es
    in vec3 p; in vec3 n; uniform mat4 mvp; out vec3 vn;
    void main() { vn = n; gl_Position = mvp * vec4(p, 1.0); }`;
  // Each primitive in its material's flat colour (linear; the topology's `color`: base colour times
  // its texture's mean), lit from the viewer's upper left, both sides.
  const fs = `#version 300 es
    precision highp float; in vec3 vn; uniform vec3 light; uniform vec4 base; out vec4 color;
    void main() { vec3 N = normalize(vn); if (!gl_FrontFacing) N = -N; float d = max(dot(N, light), 0.0);
      vec3 h = normalize(light + vec3(0, 0, 1)); float s = pow(max(dot(N, h), 0.0), 40.0);
      color = vec4(pow(base.rgb * (0.22 + 0.85 * d) + vec3(0.18) * s, vec3(1.0 / 2.2)), base.a); }`;
  const shader = (type, src) => { const s = c.createShader(type); c.shaderSource(s, src); c.compileShader(s); return s; };
  const prog = c.createProgram();
  c.attachShader(prog, shader(c.VERTEX_SHADER, vs));
  c.attachShader(prog, shader(c.FRAGMENT_SHADER, fs));
  c.linkProgram(prog);
  const vao = c.createVertexArray();
  const pbuf = c.createBuffer(), nbuf = c.createBuffer(), ibuf = c.createBuffer();
  c.bindVertexArray(vao);
  for (const [buf, name] of [[pbuf, 'p'], [nbuf, 'n']]) {
    const loc = c.getAttribLocation(prog, name);
    c.bindBuffer(c.ARRAY_BUFFER, buf);
    c.enableVertexAttribArray(loc);
    c.vertexAttribPointer(loc, 3, c.FLOAT, false, 0, 0);
  }
  let framed = false;

  let focus = null;  // The box where the shapes act (a face on a whole body), from the topology route.
  let triangles = new Uint32Array(0);
  function setTopology(topology) {
    focus = topology.focus || null;
    const tris = [];
    let base = 0;
    view.draws = [];
    for (const p of topology.primitives) {
      const first = tris.length;
      if (p.mode === 4) for (const i of p.indices) tris.push(i + base);
      base += p.vertices;
      // A see-through material (alpha 0: Uka's blush until its morph shows it) is not drawn.
      const color = p.color || [0.78, 0.72, 0.68, 1];
      if (tris.length > first && color[3] > 0.02) view.draws.push({ first, count: tris.length - first, color });
    }
    view.draws.sort((a, b) => (b.color[3] >= 1) - (a.color[3] >= 1));  // Opaque first, then blended.
    view.vertices = base;
    c.bindVertexArray(vao);
    c.bindBuffer(c.ELEMENT_ARRAY_BUFFER, ibuf);
    triangles = new Uint32Array(tris);
    weld = null;
    c.bufferData(c.ELEMENT_ARRAY_BUFFER, triangles, c.STATIC_DRAW);
    framed = false;
  }

  // Positions alone (the live socket's delta frames): the normals made here, each vertex's the sum of
  // its triangles' (area-weighted) normals, shared by the vertices a texture seam split at one place
  // (found in the first frame after a topology: `weld`, each vertex's first at its place), so seams
  // do not show. `frame` is kept between calls: no allocation a frame.
  let frame = new Float32Array(0), weld = null;
  function updatePositions(pos) {
    const n = view.vertices * 3;
    if (pos.length !== n) return;
    if (frame.length !== 2 * n) frame = new Float32Array(2 * n);
    if (!weld || weld.length !== n / 3) {
      weld = new Uint32Array(n / 3);
      const first = new Map();
      for (let v = 0; v < n / 3; ++v) {
        const key = `${pos[3 * v]},${pos[3 * v + 1]},${pos[3 * v + 2]}`;
        if (!first.has(key)) first.set(key, v);
        weld[v] = first.get(key);
      }
    }
    frame.set(pos);
    const nor = frame.subarray(n);
    nor.fill(0);
    for (let t = 0; t < triangles.length; t += 3) {
      const a = 3 * triangles[t], b = 3 * triangles[t + 1], d = 3 * triangles[t + 2];
      const ux = pos[b] - pos[a], uy = pos[b + 1] - pos[a + 1], uz = pos[b + 2] - pos[a + 2];
      const vx = pos[d] - pos[a], vy = pos[d + 1] - pos[a + 1], vz = pos[d + 2] - pos[a + 2];
      const x = uy * vz - uz * vy, y = uz * vx - ux * vz, z = ux * vy - uy * vx;
      for (const i of [a, b, d]) {
        const w = 3 * weld[i / 3];
        nor[w] += x; nor[w + 1] += y; nor[w + 2] += z;
      }
    }
    for (let v = 0; v < n / 3; ++v) {
      const w = 3 * weld[v], i = 3 * v;
      const l = Math.hypot(nor[w], nor[w + 1], nor[w + 2]) || 1;
      if (w === i) { nor[i] /= l; nor[i + 1] /= l; nor[i + 2] /= l; }
      else { nor[i] = nor[w]; nor[i + 1] = nor[w + 1]; nor[i + 2] = nor[w + 2]; }
    }
    update(frame);
  }

  function update(f32) {
    const n = view.vertices * 3;
    if (f32.length !== 2 * n) return;  // Positions then normals, every primitive in order.
    const pos = f32.subarray(0, n);
    if (!framed) {
      let lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
      if (focus) [lo, hi] = [focus.min, focus.max];
      else for (let i = 0; i < n; ++i) { lo[i % 3] = Math.min(lo[i % 3], pos[i]); hi[i % 3] = Math.max(hi[i % 3], pos[i]); }
      view.center = lo.map((l, i) => (l + hi[i]) / 2);
      // The focus (the face its expressions move) with a 40% margin, as the renders frame it: the eyes and
      // mouth inside while a motion moves the head a little; ears and hair may crop.
      view.radius = (focus ? 1.4 : 1) * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) / 2 || 1;
      framed = true;
    }
    c.bindBuffer(c.ARRAY_BUFFER, pbuf);
    c.bufferData(c.ARRAY_BUFFER, pos, c.DYNAMIC_DRAW);
    c.bindBuffer(c.ARRAY_BUFFER, nbuf);
    c.bufferData(c.ARRAY_BUFFER, f32.subarray(n), c.DYNAMIC_DRAW);
    draw();
  }

  function mul(a, b) {
    const r = new Float32Array(16);
    for (let i = 0; i < 4; ++i) for (let j = 0; j < 4; ++j) {
      let s = 0;
      for (let k = 0; k < 4; ++k) s += a[k * 4 + j] * b[i * 4 + k];
      r[i * 4 + j] = s;
    }
    return r;
  }

  function draw() {
    const dist = view.radius / Math.tan(Math.PI / 12) / view.zoom;
    const near = dist / 100, far = dist + 4 * view.radius, f = 1 / Math.tan(Math.PI / 12);
    const proj = new Float32Array([f, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) / (near - far), -1, 0, 0, 2 * far * near / (near - far), 0]);
    const cy = Math.cos(view.yaw), sy = Math.sin(view.yaw), cp = Math.cos(view.pitch), sp = Math.sin(view.pitch);
    const rot = new Float32Array([cy, sp * sy, -cp * sy, 0, 0, cp, sp, 0, sy, -sp * cy, cp * cy, 0, 0, 0, 0, 1]);
    const [x, y, z] = view.center;
    const move = new Float32Array([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -x, -y, -z, 1]);
    const back = new Float32Array([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, -dist, 1]);
    const mvp = mul(proj, mul(back, mul(rot, move)));
    c.viewport(0, 0, canvas.width, canvas.height);
    c.clearColor(0.86, 0.87, 0.89, 1);
    c.clear(c.COLOR_BUFFER_BIT | c.DEPTH_BUFFER_BIT);
    c.enable(c.DEPTH_TEST);
    c.useProgram(prog);
    c.uniformMatrix4fv(c.getUniformLocation(prog, 'mvp'), false, mvp);
    // Light from the viewer's upper left, in model space (the inverse rotation of the view).
    const l = [-0.4, 0.5, 0.77];
    c.uniform3f(c.getUniformLocation(prog, 'light'), rot[0] * l[0] + rot[1] * l[1] + rot[2] * l[2],
                rot[4] * l[0] + rot[5] * l[1] + rot[6] * l[2], rot[8] * l[0] + rot[9] * l[1] + rot[10] * l[2]);
    c.bindVertexArray(vao);
    const base = c.getUniformLocation(prog, 'base');
    for (const d of view.draws) {
      const blend = d.color[3] < 1;
      if (blend) { c.enable(c.BLEND); c.blendFunc(c.SRC_ALPHA, c.ONE_MINUS_SRC_ALPHA); c.depthMask(false); }
      c.uniform4fv(base, d.color);
      c.drawElements(c.TRIANGLES, d.count, c.UNSIGNED_INT, d.first * 4);
      if (blend) { c.disable(c.BLEND); c.depthMask(true); }
    }
  }

  drag(canvas, (dx, dy) => { view.yaw += dx * 0.01; view.pitch = Math.max(-1.5, Math.min(1.5, view.pitch + dy * 0.01)); draw(); });
  canvas.addEventListener('wheel', (e) => { e.preventDefault(); view.zoom = Math.max(0.3, Math.min(8, view.zoom * Math.exp(-e.deltaY * 0.001))); draw(); });
  // Pixels that are not background, read right after a draw (for tests and a quick health check).
  function coverage() {
    draw();
    const px = new Uint8Array(canvas.width * canvas.height * 4);
    c.readPixels(0, 0, canvas.width, canvas.height, c.RGBA, c.UNSIGNED_BYTE, px);
    let n = 0;
    for (let i = 0; i < px.length; i += 4) n += Math.abs(px[i] - 219) + Math.abs(px[i + 2] - 227) > 12 ? 1 : 0;
    return n / (canvas.width * canvas.height);
  }
  return { update, updatePositions, setTopology, view, coverage };
}

export function drag(el, move, end) {
  let last = null;
  el.addEventListener('pointerdown', (e) => { last = [e.clientX, e.clientY]; el.setPointerCapture(e.pointerId); });
  el.addEventListener('pointermove', (e) => {
    if (!last) return;
    move(e.clientX - last[0], e.clientY - last[1]);
    last = [e.clientX, e.clientY];
  });
  el.addEventListener('pointerup', () => { last = null; if (end) end(); });
}

