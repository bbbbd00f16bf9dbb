// An interactive 3D view of a mesh file (three.js): drag to rotate, wheel to zoom, right-drag to
// pan; arrow keys rotate and +/- zoom when the canvas has focus. Renders on demand only.
// Loaded lazily (its own bundle chunk) the first time a mesh is shown.

import {
  AmbientLight, BufferAttribute, BufferGeometry, Color, DirectionalLight, DoubleSide, HemisphereLight, Mesh,
  MeshStandardMaterial, PerspectiveCamera, Scene, Spherical, Vector3, WebGLRenderer,
} from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { OBJLoader } from 'three/addons/loaders/OBJLoader.js';
import { PLYLoader } from 'three/addons/loaders/PLYLoader.js';
import { STLLoader } from 'three/addons/loaders/STLLoader.js';

export const BACKGROUND = 0xf3f5f7;
const KEY_ROTATE_RAD = Math.PI / 18;
const KEY_ZOOM = 1.15;

/** A BufferGeometry from the bytes of an OBJ, PLY (ASCII or binary) or STL file. */
export function parseMesh(bytes, format) {
  if (format === 'obj') {
    // OBJLoader makes one mesh per object or group (o, g, usemtl): join their triangles.
    const parts = [];
    new OBJLoader().parse(new TextDecoder().decode(bytes)).traverse((node) => {
      if (node.isMesh) parts.push(node.geometry);
    });
    if (!parts.length) throw new Error('the OBJ file holds no faces');
    if (parts.length === 1) return parts[0];
    const arrays = parts.map((g) => g.getAttribute('position').array);
    const positions = new Float32Array(arrays.reduce((n, a) => n + a.length, 0));
    arrays.reduce((at, a) => { positions.set(a, at); return at + a.length; }, 0);
    return new BufferGeometry().setAttribute('position', new BufferAttribute(positions, 3));
  }
  if (format.startsWith('ply')) return new PLYLoader().parse(bytes);
  if (format.startsWith('stl')) return new STLLoader().parse(bytes);
  throw new Error(`no preview for format ${format}`);
}

export class MeshPreview {
  /** @throws Error when the browser has no WebGL. */
  constructor(canvas) {
    this.canvas = canvas;
    // preserveDrawingBuffer: the view can be saved (and read back) after it is shown.
    this.renderer = new WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.scene = new Scene();
    this.scene.background = new Color(BACKGROUND);
    this.camera = new PerspectiveCamera(35, 4 / 3, 0.001, 10);
    this.scene.add(new HemisphereLight(0xffffff, 0x8090a0, 1.4));
    this.scene.add(new AmbientLight(0xffffff, 0.2));
    const key = new DirectionalLight(0xffffff, 1.6);
    key.position.set(1, 1, 2);
    this.camera.add(key); // the key light follows the viewer
    this.scene.add(this.camera);
    this.material = new MeshStandardMaterial({
      color: 0x3f7fbf, roughness: 0.55, metalness: 0.05, side: DoubleSide,
    });
    this.mesh = null;
    this.center = new Vector3(); // what the view turns about
    this.controls = new OrbitControls(this.camera, canvas);
    this.controls.addEventListener('change', () => this.render());
    canvas.addEventListener('keydown', (event) => this.onKey(event));
    this.resizeObserver = new ResizeObserver(() => this.resize());
    this.resizeObserver.observe(canvas);
    this.resize();
  }

  /** Shows a new mesh, replacing the previous one, and frames it. */
  show(geometry) {
    if (this.mesh) {
      this.scene.remove(this.mesh);
      this.mesh.geometry.dispose();
    }
    if (!(geometry instanceof BufferGeometry)) throw new Error('not a mesh');
    geometry.computeBoundingSphere();
    const { center, radius } = geometry.boundingSphere;
    geometry.translate(-center.x, -center.y, -center.z);
    if (!geometry.getAttribute('normal')) geometry.computeVertexNormals();
    this.mesh = new Mesh(geometry, this.material);
    this.scene.add(this.mesh);
    this.radius = radius > 0 ? radius : 1;
    this.resetView();
  }

  resetView() {
    const r = this.radius || 1;
    const distance = r / Math.sin((this.camera.fov * Math.PI) / 360) * 1.15;
    this.camera.near = distance / 100;
    this.camera.far = distance * 100;
    this.camera.position.set(distance * 0.6, -distance * 0.5, distance * 0.62).add(this.center);
    this.camera.up.set(0, 0, 1); // meshes are z-up, like the world frame of sim/scene
    this.controls.target.copy(this.center);
    this.controls.minDistance = r * 0.2;
    this.controls.maxDistance = distance * 20;
    this.camera.updateProjectionMatrix();
    this.controls.update();
    this.render();
  }

  onKey(event) {
    const offset = new Vector3().subVectors(this.camera.position, this.controls.target);
    const spherical = new Spherical().setFromVector3(
      new Vector3(offset.x, offset.z, -offset.y)); // three's Spherical is y-up; ours is z-up
    let handled = true;
    switch (event.key) {
      case 'ArrowLeft': spherical.theta -= KEY_ROTATE_RAD; break;
      case 'ArrowRight': spherical.theta += KEY_ROTATE_RAD; break;
      case 'ArrowUp': spherical.phi = Math.max(0.05, spherical.phi - KEY_ROTATE_RAD); break;
      case 'ArrowDown': spherical.phi = Math.min(Math.PI - 0.05, spherical.phi + KEY_ROTATE_RAD); break;
      case '+': case '=': spherical.radius /= KEY_ZOOM; break;
      case '-': case '_': spherical.radius *= KEY_ZOOM; break;
      default: handled = false;
    }
    if (!handled) return;
    event.preventDefault();
    const v = new Vector3().setFromSpherical(spherical);
    this.camera.position.set(v.x, -v.z, v.y).add(this.controls.target);
    this.controls.update();
    this.render();
  }

  resize() {
    const width = Math.max(1, this.canvas.clientWidth);
    const height = Math.max(1, this.canvas.clientHeight);
    this.renderer.setSize(width, height, false);
    this.camera.aspect = width / height;
    this.camera.updateProjectionMatrix();
    this.render();
  }

  render() {
    this.renderer.render(this.scene, this.camera);
  }
}
