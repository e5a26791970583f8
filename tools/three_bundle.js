// The parts of three.js the report's viewer uses (src/dloplan/plots/report_viewer.js), bundled
// by tools/build_three_bundle.sh into src/dloplan/plots/vendor/three.min.js (global THREE).
export {
  ArrowHelper, AxesHelper, Box3, BoxGeometry, BufferAttribute, BufferGeometry, CapsuleGeometry,
  CatmullRomCurve3, Color, CylinderGeometry, DirectionalLight, EdgesGeometry, Group,
  HemisphereLight, Line, LineBasicMaterial, LineSegments, MathUtils, Matrix4, Mesh,
  MeshStandardMaterial, PCFShadowMap, PerspectiveCamera, Quaternion, Scene,
  SRGBColorSpace, TubeGeometry, Vector3, WebGLRenderer,
} from "three";
export { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";
