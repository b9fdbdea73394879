// handscs-view in a real browser (headless Chromium driven by puppeteer-core): starts the server on a
// trained run, loads the page, moves a slider with the mouse, checks that the picture changes and
// equals handscs-render's picture of the pose the page saves from the camera the server reports
// (PSNR above a bound), and optionally measures latency or takes a screenshot.
//   node browser_check.mjs --modules DIR --bin DIR --run RUN --work DIR
//        [--bench N --label NAME] [--screenshot FILE]
// Exits non-zero with a message on any failure; prints one JSON object on success.
import { createRequire } from "node:module";
import { spawn, execFileSync } from "node:child_process";
import fs from "node:fs";
import path from "node:path";

const args = {};
for (let i = 2; i < process.argv.length; i += 2) args[process.argv[i].replace(/^--/, "")] = process.argv[i + 1];
for (const key of ["modules", "bin", "run", "work"])
  if (!args[key]) throw new Error(`--${key} is required`);
const require = createRequire(path.join(path.resolve(args.modules), "node_modules", "index.js"));
const puppeteer = require("puppeteer-core");

// The page shows JPEG (quality 90, 4:2:0 chroma), decoded by the browser; handscs-render writes the
// exact PNG. JPEG's error on these frames measures 40-47 dB (the server test: 40.1 and 43.8 dB on
// small views full of edges; this page's 512x334 frame: 46.5 dB), while the picture before the
// slider moved, against the same reference, measures ~30 dB: 38 dB separates the two.
const kMinPsnr = 38;
const kTimeoutMs = 60000;

function fail(message) {
  throw new Error(message);
}

function startServer(work) {
  const saved = path.join(work, "saved_poses.json");
  fs.rmSync(saved, { force: true });
  const server = spawn(path.join(args.bin, "handscs-view"),
    ["--checkpoint", args.run, "--port", "0", "--threads", "1", "--save-poses", saved],
    { stdio: ["ignore", "pipe", "pipe"] });
  let log = "";
  const port = new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error("handscs-view did not start:\n" + log)), kTimeoutMs);
    const read = (chunk) => {
      log += chunk;
      const m = log.match(/serving http:\/\/127\.0\.0\.1:(\d+)\//);
      if (m) { clearTimeout(timer); resolve(Number(m[1])); }
    };
    server.stdout.on("data", read);
    server.stderr.on("data", read);
    server.on("exit", (code) => reject(new Error(`handscs-view exited (${code}):\n` + log)));
  });
  return { server, port, saved, log: () => log };
}

// Waits until the page has drawn at least `frames` frames and has nothing in flight or pending.
async function settled(page, frames) {
  await page.waitForFunction(
    (n) => window.handscsView && window.handscsView.ready && window.handscsView.frames >= n && !window.handscsView.busy(),
    { timeout: kTimeoutMs, polling: 20 }, frames);
  const error = await page.evaluate(() => window.handscsView.lastError);
  if (error) fail("the page reports: " + error);
}

const canvasPng = (page) => page.evaluate(() => document.getElementById("frame").toDataURL("image/png"));

// PSNR (dB, RGB, 8-bit) of two images given as data URLs, decoded by the browser in `page` (a blank
// page: the viewer's own allows no data: URLs).
async function psnr(page, a, b) {
  return page.evaluate(async (a, b) => {
    const pixels = async (url) => {
      const bitmap = await createImageBitmap(await (await fetch(url)).blob());
      const canvas = new OffscreenCanvas(bitmap.width, bitmap.height);
      const context = canvas.getContext("2d");
      context.drawImage(bitmap, 0, 0);
      return context.getImageData(0, 0, bitmap.width, bitmap.height);
    };
    const [x, y] = [await pixels(a), await pixels(b)];
    if (x.width !== y.width || x.height !== y.height) return { error: `sizes ${x.width}x${x.height} and ${y.width}x${y.height}` };
    let sum = 0;
    for (let i = 0; i < x.data.length; i += 4)
      for (let c = 0; c < 3; ++c) { const d = x.data[i + c] - y.data[i + c]; sum += d * d; }
    const mse = sum / (x.width * x.height * 3);
    return { psnr: mse === 0 ? Infinity : 10 * Math.log10(255 * 255 / mse) };
  }, a, b);
}

const percentile = (values, p) => {
  const sorted = [...values].sort((a, b) => a - b);
  return sorted.length ? sorted[Math.min(sorted.length - 1, Math.floor(p / 100 * sorted.length))] : null;
};

async function clickSlider(page, key, fraction) {
  const input = await page.$(`#control-${key.replace(".", "\\.")}`);
  if (!input) fail(`no slider ${key} on the page`);
  await input.evaluate((e) => e.scrollIntoView({ block: "center" }));  // the panel scrolls (the save button)
  const box = await input.boundingBox();
  await page.mouse.click(box.x + box.width * fraction, box.y + box.height / 2);
}

async function main() {
  const work = path.resolve(args.work);
  fs.mkdirSync(work, { recursive: true });
  const { server, port: portPromise, saved, log } = startServer(work);
  let browser;
  const result = {};
  try {
    const port = await portPromise;
    const url = `http://127.0.0.1:${port}/`;
    browser = await puppeteer.launch({
      executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
      headless: true,
      // As root without a sandbox; no background connections (the machine's network is closed).
      args: ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
             "--disable-component-update", "--disable-sync", "--force-color-profile=srgb"],
      userDataDir: path.join(work, "chromium-profile"),
    });
    const page = await browser.newPage();
    await page.setViewport({ width: 900, height: 640 });
    const pageErrors = [];
    page.on("pageerror", (e) => pageErrors.push(String(e)));
    await page.goto(url, { waitUntil: "load", timeout: kTimeoutMs });
    await settled(page, 1);
    result.gaussians = await page.evaluate(() => window.handscsView.info.gaussians);
    const before = await canvasPng(page);

    // Two hands: the sliders pose the left one (the right keeps its values).
    result.hands = await page.evaluate(() => window.handscsView.info.hands);
    const twoHands = result.hands.length === 2;
    if (twoHands) {
      if (await page.$eval("#hand-row", (e) => e.hidden)) fail("two hands, but the page shows no hand switch");
      await page.click("#hand-left");
    }

    // Move a slider with the mouse: index MCP to ~80% of its range.
    const frames = await page.evaluate(() => window.handscsView.frames);
    await clickSlider(page, "index.mcp", 0.8);
    await settled(page, frames + 1);
    const moved = await page.evaluate(() => window.handscsView.controls["index.mcp"]);
    if (!(moved > 0.5)) fail(`the slider click set index.mcp to ${moved}`);
    const after = await canvasPng(page);
    if (after === before) fail("the picture did not change when the slider moved");
    if (twoHands) {
      const sent = await page.evaluate(() => window.handscsView.request().controls);
      if (!(sent.left["index.mcp"] > 0.5) || sent.right["index.mcp"] !== 0)
        fail("the request does not hold the left hand's move alone: " + JSON.stringify(sent));
    }

    // Save the pose with the page's button; ask the server for the camera of the same state.
    await page.click("#save");
    await page.waitForFunction(() => window.handscsView.saved, { timeout: kTimeoutMs });
    const camera = await page.evaluate(async () => {
      const r = await fetch("/api/camera", { method: "POST", headers: { "Content-Type": "application/json" },
                                             body: JSON.stringify(window.handscsView.request()) });
      return r.json();
    });
    fs.writeFileSync(path.join(work, "camera.json"), JSON.stringify(camera, null, 1));
    fs.writeFileSync(path.join(work, "browser.png"), Buffer.from(after.split(",")[1], "base64"));

    // handscs-render of the saved POSES file from that camera: the independent reference.
    const renderDir = path.join(work, "render");
    fs.rmSync(renderDir, { recursive: true, force: true });
    execFileSync(path.join(args.bin, "handscs-render"),
      ["--checkpoint", args.run, "--poses", saved, "--camera", path.join(work, "camera.json"), "--out", renderDir,
       "--threads", "1"], { stdio: ["ignore", "ignore", "inherit"] });
    const reference = "data:image/png;base64," + fs.readFileSync(path.join(renderDir, "frame_0000.png")).toString("base64");
    const blank = await browser.newPage();
    const match = await psnr(blank, after, reference);
    const stale = await psnr(blank, before, reference);
    await blank.close();
    if (match.error || stale.error) fail("cannot compare: " + (match.error || stale.error));
    result.psnr_against_render_db = match.psnr;
    result.psnr_before_slider_db = stale.psnr;
    if (!(match.psnr > kMinPsnr)) fail(`the page's picture is ${match.psnr.toFixed(2)} dB from handscs-render's (bound ${kMinPsnr})`);
    if (!(stale.psnr < kMinPsnr)) fail(`the picture before the slider moved is as close (${stale.psnr.toFixed(2)} dB): the check cannot tell poses apart`);

    // What the page shows: the Gaussian count and the server's frame time.
    const shown = await page.evaluate(() => [document.getElementById("gaussians").textContent,
                                             document.getElementById("frame-ms").textContent]);
    if (shown[0].replace(/,/g, "") !== String(result.gaussians)) fail(`the page shows ${shown[0]} Gaussians`);
    if (!(parseFloat(shown[1]) > 0)) fail(`the page shows a frame time of "${shown[1]}"`);

    // Latest state only: 20 slider changes in one burst render at most 2 frames (the one in flight
    // when the burst starts, then the last state), never a queue of 20.
    const burst = await page.evaluate(async () => {
      const view = window.handscsView;
      const first = view.frames;
      const input = document.getElementById("control-ring.mcp");
      for (let k = 1; k <= 20; ++k) {
        input.value = (k / 20).toFixed(2);
        input.dispatchEvent(new Event("input"));
      }
      return first;
    });
    await settled(page, burst + 1);
    result.frames_for_20_changes = (await page.evaluate(() => window.handscsView.frames)) - burst;
    if (result.frames_for_20_changes > 2) fail(`20 quick changes rendered ${result.frames_for_20_changes} frames`);
    if (await page.evaluate(() => window.handscsView.controls["ring.mcp"]) !== 1) fail("the burst's last value was not kept");

    if (args.bench) {
      // End to end in the browser: a slider change (a new pose: the full forward) and an orbit drag
      // step (the same pose: rasterisation only), each waited for before the next. Slider clicks land
      // away from the thumb (a click on it changes nothing) and on a new value each time.
      const count = Number(args.bench);
      await page.evaluate(() => { window.handscsView.inputToFrame.length = 0; window.handscsView.roundTrips.length = 0; });
      const serverMs = { pose: [], orbit: [] };
      const measure = async (kind, act) => {
        for (let k = 0; k < count; ++k) {
          const n = await page.evaluate(() => window.handscsView.frames);
          await act(k);
          await settled(page, n + 1);
          serverMs[kind].push(await page.evaluate(() => window.handscsView.lastFrameMs));
        }
        const latencies = await page.evaluate(() => window.handscsView.inputToFrame.splice(0));
        return { frames: latencies.length, input_to_frame_ms: { p50: percentile(latencies, 50), p90: percentile(latencies, 90), max: Math.max(...latencies) },
                 server_frame_ms: { p50: percentile(serverMs[kind], 50), p90: percentile(serverMs[kind], 90) } };
      };
      result.label = args.label || null;
      result.slider = await measure("pose", (k) => clickSlider(page, "middle.pip", 0.3 + 0.6 * ((k % 7) / 7)));
      const canvas = await (await page.$("#frame")).boundingBox();
      result.orbit = await measure("orbit", async (k) => {
        const x = canvas.x + canvas.width / 2, y = canvas.y + canvas.height / 2;
        await page.mouse.move(x, y);
        await page.mouse.down();
        await page.mouse.move(x + 12, y, { steps: 1 });
        await page.mouse.up();
      });
    }
    if (args.screenshot) {
      await page.select("#gesture", String(await page.evaluate(() =>
        window.handscsView.info.gestures.findIndex((g) => g.name === "peace"))));
      const n = await page.evaluate(() => window.handscsView.frames);
      await settled(page, n + 1);
      await page.evaluate(() => { document.getElementById("panel").scrollTop = 0; });
      await page.screenshot({ path: args.screenshot });
      result.screenshot = args.screenshot;
    }
    if (pageErrors.length) fail("errors on the page: " + pageErrors.join("; "));
  } finally {
    if (browser) await browser.close();
    server.kill("SIGTERM");
  }
  console.log(JSON.stringify(result, null, 1));
}

main().catch((e) => {
  console.error("browser check FAILED: " + (e && e.message ? e.message : e));
  process.exit(1);
});
