// The report's 3D viewer (three.js, vendored in plots/vendor/three.min.js as the global THREE).
//
// Reads the JSON of the script element "plan-data" (dloplan.plots.report.report_html):
// the cable's planned and stabilized shapes, the clip frames, obstacles, the table, both arms
// (kinematic chain from the URDF joint origins and axes, visual meshes or capsules, joint
// values per time of the verified program) and the timeline. The arms are a scene graph
// base -> (joint origin -> joint rotation about its axis) x n, so setting the joint angles is
// the forward kinematics; between two timeline samples the joints and the cable are
// interpolated linearly. Z is up (the plan's frame), lengths in metres.
"use strict";
(function () {
  const data = JSON.parse(document.getElementById("plan-data").textContent);
  const root = document.getElementById("viewer3d");
  const errors = [];
  window.addEventListener("error", e => {
    errors.push(String(e.message));
    document.body.dataset.errors = errors.join(" | ");
  });
  const T = window.THREE;
  let renderer;
  try {
    renderer = new T.WebGLRenderer({antialias: true, preserveDrawingBuffer: true});
  } catch (err) {
    root.querySelector(".nogl").hidden = false;
    document.body.dataset.webgl = "false";
    document.body.dataset.rendered = "true";
    return;
  }
  document.body.dataset.webgl = "true";
  const canvasBox = root.querySelector(".canvas");
  renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
  renderer.shadowMap.enabled = true;
  renderer.shadowMap.type = T.PCFShadowMap;
  canvasBox.appendChild(renderer.domElement);
  const scene = new T.Scene();
  scene.background = new T.Color(0xe9edf1);
  const camera = new T.PerspectiveCamera(35, 1, 0.01, 50);
  camera.up.set(0, 0, 1);
  const controls = new T.OrbitControls(camera, renderer.domElement);
  controls.screenSpacePanning = true;
  controls.zoomToCursor = true;

  // --- lights: sky/ground fill, a key light casting shadows on the table, a rim light
  scene.add(new T.HemisphereLight(0xffffff, 0x8a8070, 1.6));
  const key = new T.DirectionalLight(0xffffff, 2.2);
  key.castShadow = true;
  key.shadow.mapSize.set(2048, 2048);
  key.shadow.bias = -0.0005;
  scene.add(key, key.target);
  const rim = new T.DirectionalLight(0xffffff, 0.8);
  rim.position.set(-1, 1.5, 1);
  scene.add(rim);

  const srgb = (rgb) => new T.Color().setRGB(rgb[0], rgb[1], rgb[2], T.SRGBColorSpace);
  const materials = new Map();
  function material(rgb, options) {
    const id = JSON.stringify([rgb, options || {}]);
    if (!materials.has(id)) {
      materials.set(id, new T.MeshStandardMaterial(Object.assign(
        {color: srgb(rgb), roughness: 0.55, metalness: 0.05}, options || {})));
    }
    return materials.get(id);
  }
  const layers = {};  // name -> Group, toggled by the checkboxes
  for (const name of ["robot", "planned", "stabilized", "shapes", "frames", "obstacles"]) {
    layers[name] = new T.Group();
    scene.add(layers[name]);
  }

  // --- decoding the quantized meshes (dloplan.plots.robot_meshes.encoded_meshes)
  function bytes(b64) {
    const text = atob(b64), out = new Uint8Array(text.length);
    for (let i = 0; i < text.length; i++) out[i] = text.charCodeAt(i);
    return out.buffer;
  }
  const geometries = new Map();
  function meshGroup(key) {
    if (!geometries.has(key)) {
      geometries.set(key, data.meshes[key].map(piece => {
        const q = new Uint16Array(bytes(piece.positions)), n = new Int8Array(bytes(piece.normals));
        const [lo, hi] = piece.bounds, pos = new Float32Array(q.length), nor = new Float32Array(n.length);
        for (let i = 0; i < q.length; i++) {
          const a = i % 3;
          pos[i] = lo[a] + (hi[a] - lo[a]) * q[i] / 65535;
          nor[i] = n[i] / 127;
        }
        const g = new T.BufferGeometry();
        g.setAttribute("position", new T.BufferAttribute(pos, 3));
        g.setAttribute("normal", new T.BufferAttribute(nor, 3));
        const idx = piece.index_bytes === 2 ? new Uint16Array(bytes(piece.indices))
          : new Uint32Array(bytes(piece.indices));
        g.setIndex(new T.BufferAttribute(idx, 1));
        return {geometry: g, colour: piece.colour};
      }));
    }
    const group = new T.Group();
    for (const piece of geometries.get(key)) {
      const m = new T.Mesh(piece.geometry, material(piece.colour));
      m.castShadow = true;
      m.receiveShadow = true;
      group.add(m);
    }
    return group;
  }

  function placed(object, xyz, quaternion) {
    object.position.fromArray(xyz);
    object.quaternion.fromArray(quaternion);
    return object;
  }

  const ALONG_Y = new T.Vector3(0, 1, 0);
  function rod(p0, p1, radius, mat, capsule) {  // a cylinder (or capsule) from p0 to p1
    const a = new T.Vector3().fromArray(p0), b = new T.Vector3().fromArray(p1);
    const length = a.distanceTo(b);
    const g = capsule ? new T.CapsuleGeometry(radius, length, 6, 16)
      : new T.CylinderGeometry(radius, radius, length, 24);
    const m = new T.Mesh(g, mat);
    m.position.copy(a).add(b).multiplyScalar(0.5);
    if (length > 0) m.quaternion.setFromUnitVectors(ALONG_Y, b.clone().sub(a).divideScalar(length));
    m.castShadow = true;
    return m;
  }

  // --- the arms: base -> joint origins -> joint rotations; parts hang on links
  const ARM_CAPSULE = [[0.93, 0.6, 0.2], [0.45, 0.7, 0.45]];  // left, right: not the cable's blue
  const arms = (data.robot ? data.robot.arms : []).map((arm, a) => {
    const base = placed(new T.Group(), arm.base.xyz, arm.base.quaternion);
    layers.robot.add(base);
    const links = [], axes = [];
    let parent = base;
    for (const joint of arm.joints) {
      const origin = placed(new T.Group(), joint.xyz, joint.quaternion);
      const turn = new T.Group();
      origin.add(turn);
      parent.add(origin);
      links.push(turn);
      axes.push(new T.Vector3().fromArray(joint.axis));
      parent = turn;
    }
    const link = i => (i < 0 ? base : links[i]);
    for (const part of arm.parts || []) {
      link(part.link).add(placed(meshGroup(part.mesh), part.xyz, part.quaternion));
    }
    for (const c of arm.capsules || []) {
      link(c.link).add(rod(c.ends[0], c.ends[1], c.radius, material(ARM_CAPSULE[a % 2]), true));
    }
    const last = links[links.length - 1];
    const tcp = placed(new T.Group(), arm.tcp.xyz, arm.tcp.quaternion);
    last.add(tcp);
    if (arm.generic_gripper) last.add(genericGripper(arm));
    return {links, axes, tcp};
  });

  function genericGripper(arm) {  // a parallel gripper from the flange to the TCP
    const g = new T.Group(), dark = material([0.25, 0.27, 0.3]), steel = material([0.62, 0.64, 0.66]);
    const tip = new T.Vector3().fromArray(arm.tip.xyz), tcp = new T.Vector3().fromArray(arm.tcp.xyz);
    const reach = tcp.clone().sub(tip), length = reach.length();
    if (length < 1e-6) return g;
    const dir = reach.clone().divideScalar(length);
    const r = Math.max(0.6 * arm.tool_radius, 0.02);
    const bodyEnd = tip.clone().addScaledVector(dir, 0.55 * length);
    g.add(rod(tip.toArray(), bodyEnd.toArray(), r, dark));
    const across = new T.Vector3().fromArray(arm.finger_axis);  // in the last link's frame
    for (const side of [-1, 1]) {
      const off = across.clone().multiplyScalar(side * 0.45 * r);
      g.add(rod(bodyEnd.clone().add(off).toArray(), tcp.clone().addScaledVector(dir, 0.01).add(off).toArray(),
                0.2 * r, steel));
    }
    return g;
  }

  // --- table and obstacles
  const shapes = data.shapes, n = shapes.length;
  const cableBox = new T.Box3();  // every shape of the cable: the "job" view frames it
  shapes.forEach(s => s.forEach(p => cableBox.expandByPoint(new T.Vector3().fromArray(p))));
  const box = cableBox.clone();
  if (data.robot) data.robot.arms.forEach(arm => box.expandByPoint(new T.Vector3().fromArray(arm.base.xyz)));
  const OBSTACLE = [0.55, 0.43, 0.39];
  for (const o of data.obstacles) {
    let m;
    if (o.type === "box") {
      m = new T.Mesh(new T.BoxGeometry(...o.size), material(OBSTACLE, {transparent: true, opacity: 0.85}));
      m.position.fromArray(o.center);
      m.rotation.z = o.yaw;
    } else {
      m = new T.Mesh(new T.CylinderGeometry(o.radius, o.radius, o.height, 40),
                     material(OBSTACLE, {transparent: true, opacity: 0.85}));
      m.rotation.x = Math.PI / 2;
      m.position.set(o.base[0], o.base[1], o.base[2] + o.height / 2);
    }
    m.castShadow = m.receiveShadow = true;
    const edges = new T.LineSegments(new T.EdgesGeometry(m.geometry, 30),
                                     new T.LineBasicMaterial({color: 0x4e342e}));
    m.add(edges);
    layers.obstacles.add(m);
    box.expandByObject(m);
  }
  const tl = data.timeline;
  function setJoints(i, j, f) {  // the arms' joints f of the way from sample i to sample j
    arms.forEach((arm, a) => {
      const q0 = tl.joints[a][i], q1 = tl.joints[a][j];
      arm.links.forEach((link, l) => link.quaternion.setFromAxisAngle(arm.axes[l], q0[l] + f * (q1[l] - q0[l])));
    });
  }
  setJoints(0, 0, 0);  // the table and the view fit the arms as they start
  const tableZ = data.table_height !== null ? data.table_height : box.min.z;
  scene.updateMatrixWorld(true);
  const footprint = new T.Box3().setFromObject(layers.robot).union(box);
  {
    const c = footprint.getCenter(new T.Vector3()), s = footprint.getSize(new T.Vector3());
    // the table top: the scene's footprint and 20 cm around it, in whole 20 cm, centred on a
    // whole decimetre, so the grid's lines fall on whole decimetres of the plan's frame
    const w = Math.ceil((Math.max(s.x, 0.4) + 0.4) * 5) / 5, d = Math.ceil((Math.max(s.y, 0.4) + 0.4) * 5) / 5;
    const thick = 0.03;
    const top = new T.Mesh(new T.BoxGeometry(w, d, thick), material(
      data.table_height !== null ? [0.85, 0.78, 0.66] : [0.9, 0.9, 0.9], {roughness: 0.85}));
    c.set(Math.round(c.x * 10) / 10, Math.round(c.y * 10) / 10, c.z);
    top.position.set(c.x, c.y, tableZ - thick / 2 - 0.0005);
    top.receiveShadow = true;
    scene.add(top);
    const x0 = c.x - w / 2, x1 = c.x + w / 2, y0 = c.y - d / 2, y1 = c.y + d / 2, lines = [];
    for (let x = x0; x <= x1 + 1e-9; x += 0.1) lines.push(new T.Vector3(x, y0, 0), new T.Vector3(x, y1, 0));
    for (let y = y0; y <= y1 + 1e-9; y += 0.1) lines.push(new T.Vector3(x0, y, 0), new T.Vector3(x1, y, 0));
    const grid = new T.LineSegments(new T.BufferGeometry().setFromPoints(lines),
                                    new T.LineBasicMaterial({color: 0x8f8167}));
    grid.position.z = tableZ + 0.0003;
    grid.material.transparent = true;
    grid.material.opacity = 0.55;
    scene.add(grid);
    const axes = new T.AxesHelper(0.1);  // the plan's frame: x red, y green, z blue
    axes.position.set(0, 0, tableZ + 0.001);
    scene.add(axes);
  }

  // --- the cable: tubes of the planned and the stabilized shape, all shapes as thin lines
  const radius = data.cable_radius;
  const PLANNED = [0.08, 0.4, 0.75], STABILIZED = [0.94, 0.42, 0.0];
  const plannedMat = material(PLANNED, {roughness: 0.4});
  const stabilizedMat = material(STABILIZED, {transparent: true, opacity: 0.55, roughness: 0.4});
  for (const s of shapes) {
    layers.shapes.add(new T.Line(new T.BufferGeometry().setFromPoints(s.map(p => new T.Vector3().fromArray(p))),
                                 new T.LineBasicMaterial({color: 0x9aa4ad, transparent: true, opacity: 0.6})));
  }
  const tubes = {planned: null, stabilized: null};
  function tube(layer, points, mat) {
    if (tubes[layer]) { layers[layer].remove(tubes[layer]); tubes[layer].geometry.dispose(); }
    const curve = new T.CatmullRomCurve3(points.map(p => new T.Vector3().fromArray(p)), false, "centripetal");
    const m = new T.Mesh(new T.TubeGeometry(curve, 6 * points.length, radius, 12, false), mat);
    m.castShadow = true;
    layers[layer].add(m);
    tubes[layer] = m;
  }
  const blend = (a, b, f) => a.map((p, i) => p.map((v, j) => v + f * (b[i][j] - v)));
  const FRAME_COLOURS = [0xd32f2f, 0x388e3c, 0x1976d2];  // u, v, w
  const triads = [0, 1].map(() => {
    const g = new T.Group();
    FRAME_COLOURS.forEach((colour, axis) => {
      const dir = [0, 0, 0];
      dir[axis] = 1;
      g.add(new T.ArrowHelper(new T.Vector3().fromArray(dir), new T.Vector3(), data.triad, colour,
                              0.25 * data.triad, 0.12 * data.triad));
    });
    layers.frames.add(g);
    return g;
  });
  const clipQuaternions = data.clip_rotations ? data.clip_rotations.map(shape => shape.map(m => {
    const r = new T.Matrix4().set(m[0][0], m[0][1], m[0][2], 0, m[1][0], m[1][1], m[1][2], 0,
                                  m[2][0], m[2][1], m[2][2], 0, 0, 0, 0, 1);
    return new T.Quaternion().setFromRotationMatrix(r);
  })) : null;

  // --- the timeline: times [s] (or shape numbers), the shape reached, joints per arm
  const slider = root.querySelector("#time");
  const label = root.querySelector("#time-label");
  const duration = tl.times[tl.times.length - 1] - tl.times[0];
  let now = tl.times[0];

  function sample(t) {  // index and fraction of time t between two samples
    const ts = tl.times;
    if (t <= ts[0]) return [0, 0];
    for (let i = 0; i < ts.length - 1; i++) {
      if (t <= ts[i + 1]) return [i, ts[i + 1] > ts[i] ? (t - ts[i]) / (ts[i + 1] - ts[i]) : 1];
    }
    return [ts.length - 1, 0];
  }

  function setTime(t) {
    now = Math.min(Math.max(t, tl.times[0]), tl.times[tl.times.length - 1]);
    const [i, f] = sample(now), j = Math.min(i + 1, tl.times.length - 1);
    const s = tl.shapes[i] + f * (tl.shapes[j] - tl.shapes[i]);  // fractional shape number
    const k = Math.min(Math.floor(s), n - 1), k1 = Math.min(k + 1, n - 1), g = s - k;
    tube("planned", blend(shapes[k], shapes[k1], g), plannedMat);
    if (data.stabilized) tube("stabilized", blend(data.stabilized[k], data.stabilized[k1], g), stabilizedMat);
    if (data.clip_positions) {
      triads.forEach((triad, c) => {
        const p0 = data.clip_positions[k][c], p1 = data.clip_positions[k1][c];
        triad.position.fromArray(p0.map((v, d) => v + g * (p1[d] - v)));
        triad.quaternion.copy(clipQuaternions[k][c]).slerp(clipQuaternions[k1][c], g);
      });
    }
    setJoints(i, j, f);
    slider.value = String(duration > 0 ? (now - tl.times[0]) / duration * 1000 : 0);
    const near = Math.round(s), where = Math.abs(s - near) < 1e-6 ? data.labels[near]
      : `shape ${k} \u2192 ${k1}`;
    label.textContent = (tl.unit === "s" ? `t = ${now.toFixed(2)} s of ${tl.times[tl.times.length - 1].toFixed(2)} s, `
      : "") + where;
    scene.updateMatrixWorld(true);
    document.body.dataset.tcp = JSON.stringify(arms.map(arm =>
      arm.tcp.getWorldPosition(new T.Vector3()).toArray().map(v => Number(v.toFixed(6)))));
    document.body.dataset.time = String(now);
    render();
  }

  // --- camera: views of the whole cell (fitted to the arms as they start, the cable, the
  // obstacles) or of the job (the cable's shapes, from the iso direction)
  const fits = {cell: footprint, job: cableBox.clone().expandByScalar(0.05)};
  const centre = footprint.getCenter(new T.Vector3());
  const span = footprint.getSize(new T.Vector3()).length() / 2;
  const VIEWS = {iso: [1.0, -0.75, 0.7], front: [1, 0, 0.02], side: [0, -1, 0.02], top: [-0.001, 0, 1]};
  VIEWS.reset = VIEWS.job = VIEWS.iso;
  function view(name) {
    const fit = fits[name === "job" ? "job" : "cell"];
    const middle = fit.getCenter(new T.Vector3()), radius = fit.getSize(new T.Vector3()).length() / 2;
    const dir = new T.Vector3().fromArray(VIEWS[name]).normalize();
    const distance = 0.95 * radius / Math.sin(T.MathUtils.degToRad(camera.fov / 2)) / Math.min(1, camera.aspect);
    controls.target.copy(middle);
    camera.position.copy(middle).addScaledVector(dir, distance);
    camera.near = distance / 100;
    camera.far = distance * 10 + 2 * span;
    camera.updateProjectionMatrix();
    controls.update();
    render();
  }
  key.position.copy(centre).add(new T.Vector3(0.6, -0.4, 1.5).multiplyScalar(Math.max(span, 0.5)));
  key.target.position.copy(centre);
  const cam = key.shadow.camera;
  cam.left = cam.bottom = -1.5 * span;
  cam.right = cam.top = 1.5 * span;
  cam.far = 10 * Math.max(span, 0.5);
  cam.updateProjectionMatrix();

  function resize() {
    const w = canvasBox.clientWidth, h = canvasBox.clientHeight;
    renderer.setSize(w, h, false);
    renderer.domElement.style.width = "100%";
    renderer.domElement.style.height = "100%";
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
    render();
  }
  function render() { renderer.render(scene, camera); }
  controls.addEventListener("change", render);
  window.addEventListener("resize", resize);

  // --- controls on the page
  root.querySelectorAll("[data-view]").forEach(b => b.addEventListener("click", () => view(b.dataset.view)));
  const absent = {robot: !data.robot, stabilized: !data.stabilized, frames: !data.clip_positions,
                  obstacles: !data.obstacles.length};
  root.querySelectorAll("[data-layer]").forEach(input => {
    const name = input.dataset.layer;
    if (absent[name]) {
      input.closest("label").hidden = true;
      return;
    }
    layers[name].visible = input.checked;
    input.addEventListener("change", () => { layers[name].visible = input.checked; render(); });
  });
  const play = root.querySelector("#play"), speed = root.querySelector("#speed");
  let playing = false, last = 0;  // performance.now() [ms] at the last frame played
  function step() {
    if (!playing) return;
    const stamp = performance.now(), dt = (stamp - last) / 1000;
    last = stamp;
    const rate = tl.unit === "s" ? Number(speed.value) : 2 * Number(speed.value);  // shapes per s
    const start = tl.times[0], t = now + dt * rate;  // at the end it starts again
    setTime(duration > 0 && t > start + duration ? start + (t - start) % duration : t);
    requestAnimationFrame(step);
  }
  function toggle() {
    playing = !playing;
    play.textContent = playing ? "❚❚ Pause" : "▶ Play";
    last = performance.now();  // the first frame moves on by the time since the press
    if (playing) requestAnimationFrame(step);
  }
  play.addEventListener("click", toggle);
  slider.addEventListener("input", () => {
    setTime(tl.times[0] + Number(slider.value) / 1000 * duration);
  });
  root.querySelector("#prev").addEventListener("click", () => {
    const before = tl.times.filter(t => t < now - 1e-9);
    setTime(before.length ? before[before.length - 1] : tl.times[0]);
  });
  root.querySelector("#next").addEventListener("click", () => {
    const after = tl.times.find(t => t > now + 1e-9);
    setTime(after !== undefined ? after : tl.times[tl.times.length - 1]);
  });
  renderer.domElement.addEventListener("keydown", e => {
    if (e.key === " ") { e.preventDefault(); toggle(); }
  });
  renderer.domElement.tabIndex = 0;

  // --- start: the view, time and hidden layers of the address (#t=1.5&view=top&hide=shapes,
  // &play to start playing), else iso at the start with every layer shown, paused
  const params = new URLSearchParams(location.hash.slice(1));
  for (const name of (params.get("hide") || "").split(",")) {
    const input = root.querySelector(`[data-layer="${name}"]`);
    if (input && layers[name]) { input.checked = false; layers[name].visible = false; }
  }
  resize();
  view(VIEWS[params.get("view")] ? params.get("view") : "iso");
  setTime(params.has("t") ? Number(params.get("t")) : tl.times[0]);
  if (params.has("play")) toggle();
  const rect = renderer.domElement.getBoundingClientRect();
  document.body.dataset.canvas = JSON.stringify([rect.left, rect.top, rect.width, rect.height].map(Math.round));
  document.body.dataset.rendered = "true";
})();
