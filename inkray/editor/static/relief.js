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

  // Show the GLB bytes; the first model sets the camera, later ones keep the user's view.
  async show(buffer) {
    const gltf = await new Promise((resolve, reject) => this.loader.parse(buffer, "", resolve, reject));
    const first = this.model === null && !this.framed;
    this.clear();
    this.model = gltf.scene;
    this.scene.add(this.model);
    let meshes = 0;
    this.model.traverse((o) => { if (o.isMesh) meshes += 1; });
    this.meshes = meshes;
    if (first) this.frame();
    this.draw();
    return meshes;
  }

  frame() {
    const box = new THREE.Box3().setFromObject(this.model);
    const size = box.getSize(new THREE.Vector3()), centre = box.getCenter(new THREE.Vector3());
    const radius = Math.max(size.x, size.y) * 0.5 || 1;
    const distance = radius / Math.tan((this.camera.fov * Math.PI) / 360) * 1.15;
    this.camera.position.set(centre.x + 0.35 * distance, centre.y - 0.25 * distance, centre.z + distance);
    this.camera.near = distance / 100;
    this.camera.far = distance * 10;
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(centre);
    this.controls.update();
    this.framed = true;
  }
}
