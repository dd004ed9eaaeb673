// The relief preview: a GLB from /api/preview/relief.glb in a three.js view that orbits.
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";

export class ReliefView {
  constructor(container) {
    this.container = container;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    container.appendChild(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x2a2a2a);
    this.camera = new THREE.PerspectiveCamera(30, 1, 0.001, 100);
    this.camera.position.set(0, 0, 2);
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x444444, 1.2));
    const sun = new THREE.DirectionalLight(0xffffff, 2.0);
    sun.position.set(-1, 1, 1.5);  // the CLI's default light: upper left, toward the viewer
    this.scene.add(sun);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.enableDamping = false;
    this.controls.addEventListener("change", () => this.draw());
    this.controls.addEventListener("start", () => { this.moved = true; });  // the user's own view
    this.moved = false;
    this.box = null;
    this.loader = new GLTFLoader();
    this.model = null;
    this.meshes = 0;
    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
  }

  resize() {
    const w = this.container.clientWidth || 1, h = this.container.clientHeight || 1;
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    if (this.model && !this.moved) this.frame();
    this.draw();
  }

  draw() { this.renderer.render(this.scene, this.camera); }

  clear() {
    if (this.model) {
      this.scene.remove(this.model);
      this.model.traverse((o) => { if (o.geometry) o.geometry.dispose(); });
      this.model = null;
      this.meshes = 0;
      this.draw();
    }
  }

  // Show the GLB bytes. The view is framed on the relief when its extent changes (it grew,
  // a part came or went), unless the user moved the camera since the last framing.
  async show(buffer) {
    const gltf = await new Promise((resolve, reject) => this.loader.parse(buffer, "", resolve, reject));
    this.clear();
    this.model = gltf.scene;
    this.scene.add(this.model);
    let meshes = 0;
    this.model.traverse((o) => { if (o.isMesh) meshes += 1; });
    this.meshes = meshes;
    const box = new THREE.Box3().setFromObject(this.model);
    if (!this.moved && (!this.box || !sameExtent(this.box, box))) this.frame();
    this.draw();
    return meshes;
  }

  // Frame the relief: its whole bounding box in view, seen a little from the lower right.
  frame() {
    if (!this.model) return;
    const box = new THREE.Box3().setFromObject(this.model);
    const size = box.getSize(new THREE.Vector3()), centre = box.getCenter(new THREE.Vector3());
    const radius = size.length() * 0.5 || 1;  // the bounding sphere: in view at any aspect
    const half = (this.camera.fov * Math.PI) / 360;
    const fit = Math.min(Math.tan(half), Math.tan(half) * this.camera.aspect);
    const distance = (radius / Math.sin(Math.atan(fit))) * 1.02;
    const dir = new THREE.Vector3(0.35, -0.25, 1).normalize();
    this.camera.position.copy(centre).addScaledVector(dir, distance);
    this.camera.near = distance / 100;
    this.camera.far = distance * 10;
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(centre);
    this.controls.update();
    this.box = box;
    this.moved = false;
    this.draw();
  }

  // Whether every corner of the relief's bounding box projects inside the view.
  contains() {
    if (!this.model) return false;
    const box = new THREE.Box3().setFromObject(this.model);
    this.camera.updateMatrixWorld();
    for (let i = 0; i < 8; i++) {
      const p = new THREE.Vector3(i & 1 ? box.max.x : box.min.x, i & 2 ? box.max.y : box.min.y,
                                  i & 4 ? box.max.z : box.min.z).project(this.camera);
      if (Math.abs(p.x) > 1 || Math.abs(p.y) > 1) return false;
    }
    return true;
  }
}

// Two extents are the same when no side moved by more than 2 % of the larger size.
function sameExtent(a, b) {
  const tol = 0.02 * Math.max(a.getSize(new THREE.Vector3()).length(), b.getSize(new THREE.Vector3()).length());
  return a.min.distanceTo(b.min) <= tol && a.max.distanceTo(b.max) <= tol;
}
