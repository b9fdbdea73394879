// MediaPipe Hands (npm @mediapipe/hands, its models and WASM) in headless Chromium, driven by
// puppeteer-core, over a folder of per-view images; writes each view's landmarks in the format
// `handscs-fit --multiview` reads (fit/multiview_capture.h): OUT/NN.json =
// {"Left": [63], "Right": [63]}, x, y and z each mapped from MediaPipe's [0, 1] to [-1, 1]
// (v * 2 - 1; z is MediaPipe's relative depth, which the reader ignores), [] where not detected.
// Everything loads from a local HTTP server on 127.0.0.1: no network is needed.
//   node detect_landmarks.mjs --modules DIR --images DIR --out DIR --work DIR
//        [--max-hands 2] [--model-complexity 1] [--min-confidence 0.5]
// --modules holds node_modules/ with puppeteer-core and @mediapipe/hands (detect_landmarks.sh
// installs them). Prints one JSON object: per view, the detections' labels and scores.
import { createRequire } from "node:module";
import fs from "node:fs";
import http from "node:http";
import path from "node:path";

const args = { "max-hands": "2", "model-complexity": "1", "min-confidence": "0.5" };
for (let i = 2; i < process.argv.length; i += 2) {
  const key = process.argv[i].replace(/^--/, "");
  if (!(key in args) && !["modules", "images", "out", "work"].includes(key)) throw new Error(`unknown option --${key}`);
  args[key] = process.argv[i + 1];
}
for (const key of ["modules", "images", "out", "work"]) if (!args[key]) throw new Error(`--${key} is required`);
const maxHands = Number(args["max-hands"]);
// The file holds one "Left" and one "Right" entry: two hands at most.
if (!(maxHands === 1 || maxHands === 2)) throw new Error("--max-hands takes 1 or 2");
const complexity = Number(args["model-complexity"]);
if (!(complexity === 0 || complexity === 1)) throw new Error("--model-complexity takes 0 (lite) or 1 (full)");
const minConfidence = Number(args["min-confidence"]);
if (!(minConfidence > 0 && minConfidence < 1)) throw new Error("--min-confidence takes a number in (0, 1)");

const modules = path.join(path.resolve(args.modules), "node_modules");
const require = createRequire(path.join(modules, "index.js"));
const puppeteer = require("puppeteer-core");
const mediapipe = path.join(modules, "@mediapipe", "hands");
if (!fs.existsSync(path.join(mediapipe, "hands.js"))) throw new Error(`${mediapipe}/hands.js is missing`);

const images = fs.readdirSync(args.images).filter((f) => /\.(png|jpe?g)$/i.test(f)).sort();
if (images.length === 0) throw new Error(`${args.images}: no .png or .jpg images`);
const stems = new Set();
for (const f of images) {
  const stem = f.replace(/\.[^.]+$/, "");
  if (stems.has(stem)) throw new Error(`${args.images}: two images named ${stem}`);
  stems.add(stem);
}

const pageHtml = `<!doctype html><meta charset="utf-8"><script src="/mediapipe/hands.js"></script>`;
const types = { ".js": "text/javascript", ".wasm": "application/wasm", ".png": "image/png", ".jpg": "image/jpeg",
                ".jpeg": "image/jpeg" };

// Serves the page, the package's files under /mediapipe/ and the images under /images/; nothing else.
function serve(root, prefix, url, response) {
  const name = decodeURIComponent(url.slice(prefix.length));
  if (name.includes("/") || name.startsWith(".")) return false;
  const file = path.join(root, name);
  if (!fs.existsSync(file)) return false;
  response.writeHead(200, { "Content-Type": types[path.extname(file).toLowerCase()] || "application/octet-stream" });
  fs.createReadStream(file).pipe(response);
  return true;
}

const server = http.createServer((request, response) => {
  const url = request.url.split("?")[0];
  if (url === "/") {
    response.writeHead(200, { "Content-Type": "text/html" });
    response.end(pageHtml);
    return;
  }
  if (url.startsWith("/mediapipe/") && serve(mediapipe, "/mediapipe/", url, response)) return;
  if (url.startsWith("/images/") && serve(path.resolve(args.images), "/images/", url, response)) return;
  response.writeHead(404);
  response.end();
});
await new Promise((resolve) => server.listen(0, "127.0.0.1", resolve));
const origin = `http://127.0.0.1:${server.address().port}`;

// MediaPipe's normalised coordinate v in [0, 1] over the image, as the reader's [-1, 1].
const toSigned = (v) => v * 2 - 1;

let browser;
try {
  fs.mkdirSync(args.out, { recursive: true });
  browser = await puppeteer.launch({
    executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
    headless: true,
    // As root without a sandbox; no background connections (the machine's network is closed).
    // MediaPipe's graph runs on WebGL: SwiftShader draws it on the CPU.
    args: ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--disable-quic",
           "--no-first-run", "--disable-background-networking", "--disable-component-update", "--disable-sync"],
    userDataDir: path.join(args.work, "chromium-profile"),
  });
  const page = await browser.newPage();
  page.setDefaultTimeout(120000);
  const pageErrors = [];
  page.on("pageerror", (e) => pageErrors.push(String(e)));
  await page.goto(origin + "/");
  await page.evaluate(async (options) => {
    const hands = new window.Hands({ locateFile: (file) => `/mediapipe/${file}` });
    hands.setOptions(options);
    let pending = null;
    hands.onResults((results) => { if (pending) pending(results); });
    await hands.initialize();
    const run = (image) => new Promise((resolve, reject) => {
      pending = resolve;
      hands.send({ image }).catch(reject);
    });
    // MediaPipe tracks a hand from one image to the next. A black image of the same size first
    // leaves it nothing to track, so each view is searched afresh: its landmarks equal those of
    // hands.reset() before it (which rebuilds the graph, several times slower) to the last bit.
    window.detect = async (url) => {
      const image = new Image();
      image.src = url;
      await image.decode();
      const blank = document.createElement("canvas");
      blank.width = image.naturalWidth;
      blank.height = image.naturalHeight;
      blank.getContext("2d").fillRect(0, 0, blank.width, blank.height);
      await run(blank);
      const results = await run(image);
      pending = null;
      return {
        width: image.naturalWidth, height: image.naturalHeight,
        hands: (results.multiHandLandmarks || []).map((landmarks, i) => ({
          label: results.multiHandedness[i].label,
          score: results.multiHandedness[i].score,
          landmarks: landmarks.map((p) => [p.x, p.y, p.z]),
        })),
      };
    };
  }, { selfieMode: false, maxNumHands: maxHands, modelComplexity: complexity,
       minDetectionConfidence: minConfidence, minTrackingConfidence: minConfidence });

  const summary = { images: args.images, max_hands: maxHands, model_complexity: complexity, views: {} };
  for (const file of images) {
    const stem = file.replace(/\.[^.]+$/, "");
    const found = await page.evaluate((url) => window.detect(url), `/images/${encodeURIComponent(file)}`);
    if (pageErrors.length) throw new Error("the page reports: " + pageErrors.join("; "));
    // MediaPipe's labels as it gives them (it assumes a mirrored selfie image, so on a plain
    // camera image they are usually the other hand; the reader does not trust them). Two hands
    // given one label: the one with the lower score takes the other key, so the file holds both.
    const out = { Left: [], Right: [] };
    const labels = [];
    const ordered = [...found.hands].sort((a, b) => b.score - a.score);
    for (const hand of ordered) {
      let key = hand.label;
      if (out[key].length) key = key === "Left" ? "Right" : "Left";
      out[key] = hand.landmarks.flatMap(([x, y, z]) => [toSigned(x), toSigned(y), toSigned(z)]);
      labels.push({ label: hand.label, written_as: key, score: Number(hand.score.toFixed(4)) });
    }
    fs.writeFileSync(path.join(args.out, `${stem}.json`), JSON.stringify(out) + "\n");
    summary.views[stem] = { width: found.width, height: found.height, hands: labels };
  }
  console.log(JSON.stringify(summary));
} finally {
  if (browser) await browser.close();
  server.close();
}
