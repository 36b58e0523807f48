// record_selfie.js: the reference output of the selfie segmentation network
// (models/face-models/selfie.json) on tests/data/segment/london-001-256.png, computed by TensorFlow.js's
// own CPU backend, for tests/test_tfjs_graph.c. Input: the PNG's RGB / 255 as a (1, 256, 256, 3)
// tensor; output: the (1, 256, 256, 1) probabilities written as an 8-bit grey PNG (round(255 p)).
//
//   cd tests/reference && npm ci && node record_selfie.js
//
// writes tests/data/segment/london-001-256.selfie.png (and prints the output's range).
'use strict';
const fs = require('fs');
const path = require('path');
const tf = require('@tensorflow/tfjs-core');
require('@tensorflow/tfjs-backend-cpu');
const converter = require('@tensorflow/tfjs-converter');
const { PNG } = require('pngjs');

const root = path.join(__dirname, '..', '..');
const modelJson = path.join(root, 'models', 'face-models', 'selfie.json');
const input = path.join(root, 'tests', 'data', 'segment', 'london-001-256.png');
const output = path.join(root, 'tests', 'data', 'segment', 'london-001-256.selfie.png');

async function main() {
  await tf.setBackend('cpu');
  const model = JSON.parse(fs.readFileSync(modelJson));
  const specs = [];
  const shards = [];
  for (const group of model.weightsManifest) {
    specs.push(...group.weights);
    for (const p of group.paths) shards.push(fs.readFileSync(path.join(path.dirname(modelJson), p)));
  }
  const weights = Buffer.concat(shards);
  const graph = await converter.loadGraphModel(tf.io.fromMemory({
    modelTopology: model.modelTopology,
    weightSpecs: specs,
    weightData: weights.buffer.slice(weights.byteOffset, weights.byteOffset + weights.length),
  }));
  const png = PNG.sync.read(fs.readFileSync(input));
  const n = png.width * png.height;
  const x = new Float32Array(n * 3);
  for (let i = 0; i < n; i++) for (let c = 0; c < 3; c++) x[3 * i + c] = png.data[4 * i + c] / 255;
  const y = graph.execute(tf.tensor4d(x, [1, png.height, png.width, 3]));
  const p = await y.data();
  const out = new PNG({ width: png.width, height: png.height, colorType: 0, inputColorType: 0, bitDepth: 8 });
  out.data = Buffer.alloc(n);
  let lo = 1, hi = 0;
  for (let i = 0; i < n; i++) {
    out.data[i] = Math.round(255 * p[i]);
    lo = Math.min(lo, p[i]);
    hi = Math.max(hi, p[i]);
  }
  fs.writeFileSync(output, PNG.sync.write(out, { colorType: 0, inputColorType: 0, bitDepth: 8 }));
  console.log(`${path.relative(root, output)}: ${y.shape}, ${lo} .. ${hi}`);
}

main().catch((e) => {
  console.error(e);
  process.exit(1);
});
