// Metallic-roughness sphere grids in three.js, for /three.html and for measuring three.js's
// rendering of arlight's light against the full BRDF (bench/three_spheres.mjs, the page test).
import * as THREE from 'three';

/**
 * The page's display grid: dielectric spheres on the top row, metal below, roughness rising from
 * left to right (0.05 to 1), each a glTF material's two numbers.
 */
export function sphereGrid(columns = 5) {
  const grid = new THREE.Group();
  const geometry = new THREE.SphereGeometry(0.16, 64, 32);
  for (let row = 0; row < 2; ++row)
    for (let c = 0; c < columns; ++c) {
      const roughness = 0.05 + (0.95 * c) / (columns - 1);
      const material = new THREE.MeshStandardMaterial({
        color: row === 0 ? 0xb0b0b0 : 0xf0f0f0, metalness: row, roughness,
      });
      const sphere = new THREE.Mesh(geometry, material);
      sphere.position.set((c - (columns - 1) / 2) * 0.4, row === 0 ? 0.21 : -0.21, 0);
      grid.add(sphere);
    }
  return grid;
}

/**
 * arlight-bench-pbr's grid as three.js's MeshStandardMaterial draws it under `environment`: for
 * each {metallic, roughness} of `spheres`, the unit sphere at the origin seen from `camera`
 * (arlight-bench-pbr --reference's: width, height, fy, eye; looking down -Z) with base colour
 * `baseColour` (linear RGB), no tone mapping, read back as linear RGBA floats, rows bottom-up.
 */
export function renderSpheresLinear(renderer, environment, camera, spheres, baseColour) {
  const { width, height } = camera;
  const target = new THREE.WebGLRenderTarget(width, height, { type: THREE.FloatType });
  const view = new THREE.PerspectiveCamera(
    (2 * Math.atan((0.5 * height) / camera.fy) * 180) / Math.PI, width / height, 0.1, 100);
  view.position.set(...camera.eye);
  const scene = new THREE.Scene();
  scene.environment = environment;
  const material = new THREE.MeshStandardMaterial();
  material.color.setRGB(...baseColour);  // linear: three's working colour space
  const geometry = new THREE.SphereGeometry(1, 128, 64);
  scene.add(new THREE.Mesh(geometry, material));
  const toneMapping = renderer.toneMapping;
  renderer.toneMapping = THREE.NoToneMapping;
  const previous = renderer.getRenderTarget();
  const out = spheres.map(({ metallic, roughness }) => {
    material.metalness = metallic;
    material.roughness = roughness;
    renderer.setRenderTarget(target);
    renderer.render(scene, view);
    const pixels = new Float32Array(width * height * 4);
    renderer.readRenderTargetPixels(target, 0, 0, width, height, pixels);
    return pixels;
  });
  renderer.setRenderTarget(previous);
  renderer.toneMapping = toneMapping;
  target.dispose();
  material.dispose();
  geometry.dispose();
  return out;
}
