#!/usr/bin/env node
// Produces one HTML report with the real `ctr` binary, opens it in headless Chromium and checks it: no console or
// page errors, nothing fetched from the network, the expected elements (plotted series, candidate rows, the slider
// moving the robot), and a PNG screenshot kept as a test artefact. Registered by tests/reports/CMakeLists.txt.
//
// Usage: node check_report.js --kind diagnosis|sweep|planning|bench|design --html OUT.html --png OUT.png
//          [--metrics OUT.json] [--make-path SPEC] [--min-series N] [--accept-exit 0,1]
//          [--min-robot-pixels F] -- COMMAND...
// Planning viewer: the first frame (before any interaction) is kept as OUT.first.png, and the fraction of its canvas
// pixels drawn in the robot's colours (tubes 1-3, or the collision red) must be at least F (default 0.002).
'use strict';
const fs = require('fs');
const os = require('os');
const path = require('path');
const { spawnSync } = require('child_process');

function fail(msg) {
  console.error('FAIL: ' + msg);
  process.exit(1);
}

const argv = process.argv.slice(2);
const opt = { accept: [0], minSeries: 1, minRobotPixels: 0.002 };
let cmd = [];
for (let i = 0; i < argv.length; ++i) {
  const a = argv[i];
  if (a === '--') { cmd = argv.slice(i + 1); break; }
  const v = argv[++i];
  if (a === '--kind') opt.kind = v;
  else if (a === '--html') opt.html = v;
  else if (a === '--png') opt.png = v;
  else if (a === '--metrics') opt.metrics = v;
  else if (a === '--make-path') opt.makePath = v;
  else if (a === '--min-series') opt.minSeries = Number(v);
  else if (a === '--accept-exit') opt.accept = v.split(',').map(Number);
  else if (a === '--min-robot-pixels') opt.minRobotPixels = Number(v);
  else fail('unknown option ' + a);
}
if (!opt.kind || !opt.html || !opt.png) fail('--kind, --html and --png are required');

const chromiumPath = process.env.CTR_CHROMIUM || '/usr/bin/chromium';
if (!fs.existsSync(chromiumPath))
  fail(`Chromium not found at ${chromiumPath}: install it with scripts/install-deps.sh (Debian package chromium) ` +
       'or set CTR_CHROMIUM to its path. The report tests need a headless browser.');
let chromium;
try {
  ({ chromium } = require('playwright-core'));
} catch (e) {
  fail('playwright-core not found (NODE_PATH should point at the build\'s reports/web/node_modules): ' + e.message);
}

// Optional synthetic path: "lung:ROWS:OUT.csv" interpolates a long insertion + rotation from the lung query start.
if (opt.makePath) {
  const [shape, rowsText, out] = opt.makePath.split(':');
  const rows = Number(rowsText);
  if (shape !== 'lung' || !(rows > 1) || !out) fail('bad --make-path ' + opt.makePath);
  const a0 = [0, 0, 0], a1 = [0.9, -0.7, 0.0];
  const b0 = [-0.118, -0.218, -0.318], b1 = [-0.08, -0.17, -0.26];
  let text = 'alpha_1,alpha_2,alpha_3,beta_1,beta_2,beta_3\n';
  for (let k = 0; k < rows; ++k) {
    const t = k / (rows - 1);
    const lerp = (x, y) => x + (y - x) * t;
    text += a0.map((x, i) => lerp(x, a1[i]).toFixed(7)).concat(b0.map((x, i) => lerp(x, b1[i]).toFixed(7))).join(',') + '\n';
  }
  fs.writeFileSync(out, text);
}

// 1. Produce the report.
if (cmd.length) {
  fs.rmSync(opt.html, { force: true });
  const t = Date.now();
  const r = spawnSync(cmd[0], cmd.slice(1), { encoding: 'utf8', maxBuffer: 256 << 20 });
  const secs = (Date.now() - t) / 1000;
  if (r.error) fail('could not run ' + cmd[0] + ': ' + r.error.message);
  process.stderr.write((r.stderr || '').split('\n').slice(-15).join('\n') + '\n');
  if (!opt.accept.includes(r.status)) fail(`${cmd.join(' ')} exited with ${r.status}`);
  console.log(`produced ${opt.html} in ${secs.toFixed(1)} s`);
}
if (!fs.existsSync(opt.html)) fail('no report written: ' + opt.html);
const bytes = fs.statSync(opt.html).size;
const htmlText = fs.readFileSync(opt.html, 'utf8');
if (/<script[^>]+src=|<link[^>]+href=["']?https?:/i.test(htmlText)) fail('the report references external scripts or styles');

// 2. Open it in headless Chromium with exactly the project's flags and a fresh profile.
(async () => {
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'ctr-report-profile-'));
  const browser = await chromium.launch({
    executablePath: chromiumPath,
    ignoreDefaultArgs: true,
    timeout: 60000,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--no-first-run', '--disable-background-networking',
      '--disable-component-update', '--disable-sync', '--disable-quic', `--user-data-dir=${profile}`,
      '--remote-debugging-pipe'],
  });
  const problems = [];
  try {
    const page = await browser.newPage({ viewport: { width: 1400, height: 1000 } });
    page.on('console', (m) => {
      if (m.type() === 'error') problems.push('console error: ' + m.text());
    });
    page.on('pageerror', (e) => problems.push('page error: ' + e.message));
    page.on('crash', () => problems.push('the page crashed'));
    page.on('request', (r) => {
      if (!r.url().startsWith('file://') && !r.url().startsWith('data:')) problems.push('network request: ' + r.url());
    });
    const url = 'file://' + path.resolve(opt.html);
    const t0 = Date.now();
    await page.goto(url, { waitUntil: 'load', timeout: 120000 });
    await page.waitForFunction(() => window.ctrReport && window.ctrReport.ready, null, { timeout: 120000 });
    const loadMs = Date.now() - t0;
    const info = await page.evaluate(() => ({
      kind: window.ctrReport.kind,
      charts: window.ctrReport.charts(),
      series: window.ctrReport.seriesCount(),
      data: JSON.parse(document.getElementById('ctr-data').textContent),
    }));
    const check = (cond, msg) => { if (!cond) problems.push(msg); };
    check(info.kind === opt.kind, `kind ${info.kind} != ${opt.kind}`);
    const metrics = { kind: opt.kind, html_bytes: bytes, load_ms: loadMs, charts: info.charts.length, series: info.series };
    if (opt.kind === 'diagnosis' || opt.kind === 'sweep') {
      check(info.charts.length >= 2, `only ${info.charts.length} charts`);
      check(info.series >= opt.minSeries, `only ${info.series} plotted series (expected >= ${opt.minSeries})`);
      for (const c of info.charts) check(c.points > 0 && c.series > 0, `empty chart '${c.title}'`);
    }
    if (opt.kind === 'diagnosis') {
      const d = info.data;
      const rows = await page.locator('#candidates-table tbody tr').count();
      check(rows === d.report.findings.length + 1, `candidate table has ${rows} rows, expected ${d.report.findings.length + 1}`);
      check(await page.locator('#verdict').count() === 1, 'no verdict');
      const verdict = await page.locator('#verdict .verdict-name').textContent();
      const un = d.report.unexplained;
      const want = d.report.verdict.length ? d.report.verdict.join(' + ') + (un ? ' (partial explanation)' : '')
        : (un ? 'not explained by any candidate' : 'nothing left out');
      check(verdict === want, `verdict shows '${verdict}', expected '${want}'`);
      check(!un || await page.locator('#unexplained').count() === 1, 'no unexplained section');
      check(!(d.report.failed_rows || []).length || await page.locator('#failed-rows').count() === 1, 'no failed-rows section');
      check(info.charts.some((c) => /residual vs/.test(c.title)), 'no residual-vs-configuration chart');
      check(info.charts.some((c) => /Tip position error|twist/i.test(c.title)), 'no measured-vs-model chart');
      // One row per fitted parameter of the final (full-data) model, each with its 95 % interval shown.
      const finalParams = d.report.final.effects.flatMap((e) =>
        Object.keys(e).filter((k) => !['effect', 'tube', 'interval95'].includes(k)).map((k) => `${e.effect} ${k}`));
      if (finalParams.length) {
        const prow = await page.locator('#parameters tbody tr').evaluateAll((rs) =>
          rs.map((r) => [...r.querySelectorAll('td')].map((c) => c.textContent.trim())));
        check(prow.length === finalParams.length, `parameters table has ${prow.length} rows, expected ${finalParams.length}`);
        for (const r of prow)
          check(/^\[[^\]]*\d[^\]]*\]/.test(r[3] || '') && !/–/.test(r[3]),
            `no 95 % interval shown for ${r[0]} ${r[1]} in the parameters table: '${r[3]}'`);
        metrics.parameter_rows = prow.map((r) => r.join(' | '));
      }
      metrics.candidate_rows = rows;
      metrics.recording_rows = d.recording_rows;
      metrics.plot_rows = d.plot.rows;
    }
    if (opt.kind === 'sweep') {
      const d = info.data;
      const expected = (d.tubes - 1) + 2 + (d.band.length ? 1 : 0);
      check(info.charts.length === expected, `${info.charts.length} charts, expected ${expected}`);
      const twist = info.charts.filter((c) => /Tip twist/.test(c.title));
      const dirs = new Set(d.direction).size;
      const snaps = d.snapped.some((v) => v) ? 1 : 0;
      for (const c of twist) check(c.series >= dirs + (d.band.length ? 1 : 0) && c.series <= dirs + (d.band.length ? 1 : 0) + snaps,
        `twist chart has ${c.series} series`);
    }
    if (opt.kind === 'design') {
      const d = info.data;
      check(info.charts.some((c) => /Search: feasibility/.test(c.title)), 'no search chart');
      for (const c of info.charts) check(c.points > 0, `empty chart '${c.title}'`);
      const qrows = await page.locator('#queries-table tbody tr').count();
      check(qrows === d.queries.length, `queries table has ${qrows} rows, expected ${d.queries.length}`);
      const tubes = Math.max(d.base ? d.base.tubes.length : 0, d.design ? d.design.design.length : 0);
      const trows = await page.locator('#robot-table tbody tr').count();
      check(trows === tubes, `robot table has ${trows} rows, expected ${tubes}`);
      const paths = (d.paths || []).filter((p) => p.tip_travel.length > 0);
      check(!paths.length || info.charts.some((c) => /Clearance along/.test(c.title) && c.series === paths.length),
        `no clearance chart with ${paths.length} path(s)`);
      // Every designed plan has its viewer, written beside the report.
      for (const p of paths) {
        check(p.viewer && fs.existsSync(path.join(path.dirname(opt.html), p.viewer)), `no viewer for ${p.query}`);
        check(await page.locator(`#queries-table a[href="${p.viewer}"]`).count() === 1, `no link to ${p.viewer}`);
      }
      if (d.solved) check(paths.length === d.queries.length, `solved, but ${paths.length} of ${d.queries.length} paths`);
      Object.assign(metrics, { evaluations: d.evaluations.length, queries: d.queries.length, paths: paths.length });
    }
    if (opt.kind === 'bench') {
      const d = info.data;
      const groups = new Set(d.rows.map((r) => `${r.query}/${r.mode}`)).size;
      check(info.charts.length === 3 + groups, `${info.charts.length} charts, expected ${3 + groups} (success, outcomes, ${groups} time-to-solution, strip)`);
      for (const c of info.charts) check(c.points > 0, `empty chart '${c.title}'`);
      check(info.charts.some((c) => /Success rate/.test(c.title)), 'no success-rate chart');
      check(info.charts.some((c) => /Replay outcomes/.test(c.title)), 'no replay-outcome chart');
      check(info.charts.some((c) => /Time to solution/.test(c.title)), 'no time-to-solution chart');
      const rows = await page.locator('#summary-table tbody tr').count();
      check(rows === d.rows.length, `summary table has ${rows} rows, expected ${d.rows.length}`);
      const outcomes = d.run_outcomes.length;
      check(outcomes === d.runs, `${outcomes} run outcomes for ${d.runs} runs`);
      Object.assign(metrics, { rows: d.rows.length, runs: d.runs });
    }
    if (opt.kind === 'planning') {
      // The first frame, as the page opened: the robot must be visible (not hidden behind the anatomy). Counted on
      // the WebGL canvas: pixels of the colours of tubes 1-3 (hue within 12 deg, saturation >= 3/4 of the colour's:
      // the translucent goal over the anatomy, hue ~25 deg, is paler than the orange tube) or of the collision red
      // (saturation >= 0.75; the anatomy's red, ~0.45, is paler). Nothing else in the scene has these colours.
      const firstPng = opt.png.replace(/\.png$/, '') + '.first.png';
      await page.locator('#viewport canvas').screenshot({ path: firstPng });
      const first = await page.evaluate(() => {
        const c = window.ctrReport;
        const canvas = document.querySelector('#viewport canvas');
        const w = canvas.width, hgt = canvas.height;
        const cv = document.createElement('canvas');
        cv.width = w; cv.height = hgt;
        const g = cv.getContext('2d');
        g.drawImage(canvas, 0, 0);
        const px = g.getImageData(0, 0, w, hgt).data;
        const hsv = (r, gr, b) => {
          const mx = Math.max(r, gr, b), mn = Math.min(r, gr, b), dd = mx - mn;
          let hue = 0;
          if (dd > 0) hue = mx === r ? ((gr - b) / dd) % 6 : mx === gr ? (b - r) / dd + 2 : (r - gr) / dd + 4;
          return [(hue * 60 + 360) % 360, mx > 0 ? dd / mx : 0, mx / 255];
        };
        // The viewer's colours of tubes 1-3 (planning.js tubeColor).
        const tubes = ['#4a7fb5', '#e8a33d', '#5fb35f'].slice(0, window.ctrReport.tubeCount || 3)
          .map((x) => hsv(parseInt(x.slice(1, 3), 16), parseInt(x.slice(3, 5), 16), parseInt(x.slice(5, 7), 16)));
        let tube = 0, red = 0;
        for (let k = 0; k < px.length; k += 4) {
          const [hue, sat, val] = hsv(px[k], px[k + 1], px[k + 2]);
          if (val < 0.15) continue;
          if (tubes.some(([th, ts]) => Math.min(Math.abs(hue - th), 360 - Math.abs(hue - th)) <= 12 && sat >= 0.75 * ts)) ++tube;
          else if ((hue <= 12 || hue >= 348) && sat >= 0.75 && val >= 0.3) ++red;
        }
        return { w, h: hgt, tube, red, fraction: (tube + red) / (w * hgt), current: c.current(), colors: c.tubeColors,
          firstView: c.firstView || null };
      });
      check(!first.colors || ['#4a7fb5', '#e8a33d', '#5fb35f'].every((x, i) => i >= first.colors.length || first.colors[i] === x),
        `the viewer's tube colours ${first.colors} are not the ones this test counts`);
      check(first.fraction >= opt.minRobotPixels,
        `the robot is hardly visible in the first frame: ${first.tube + first.red} of ${first.w}x${first.h} canvas pixels ` +
        `(${(100 * first.fraction).toFixed(3)} %, need ${(100 * opt.minRobotPixels).toFixed(3)} %); see ${firstPng}`);
      Object.assign(metrics, { first_frame_robot_pixels: first.tube + first.red, first_frame_robot_fraction: first.fraction,
        first_frame_waypoint: first.current, first_view: first.firstView });
      console.log(`first frame: ${first.tube} tube + ${first.red} collision-red pixels of ${first.w}x${first.h} ` +
        `(${(100 * first.fraction).toFixed(3)} %), waypoint ${first.current}; ${firstPng}`);
      const r = await page.evaluate(async () => {
        const c = window.ctrReport;
        const n = c.waypoints;
        const s0 = c.robotSignature(), m0 = c.robotMeshes();
        const f0 = c.frames();
        c.setWaypoint(Math.floor((n - 1) / 2));
        const s1 = c.robotSignature();
        // Move the slider as a user would.
        const sl = document.getElementById('waypoint-slider');
        sl.value = String(n - 1);
        sl.dispatchEvent(new Event('input', { bubbles: true }));
        const s2 = c.robotSignature();
        const t = performance.now();
        for (let k = 0; k < 50; ++k) c.setWaypoint(Math.floor((k * (n - 1)) / 49));
        const stepMs = (performance.now() - t) / 50;
        c.setWaypoint(Math.floor((n - 1) * 0.75));
        await c.nextFrame();
        return { n, m0, s0, s1, s2, current: c.current(), frames: c.frames() - f0, stepMs, voxels: c.voxels, bands: c.bands.length,
          bandVisible: c.bandVisible(), canvas: !!document.querySelector('#viewport canvas'), jsLoadMs: c.loadMs };
      });
      check(r.canvas, 'no WebGL canvas');
      check(r.m0 >= 1, 'no tube mesh');
      check(r.s1 !== r.s0 && r.s2 !== r.s1, 'the slider does not change the robot geometry');
      check(r.current === Math.floor((r.n - 1) * 0.75), 'setWaypoint did not move');
      check(r.frames > 0, 'nothing rendered');
      check(r.n === info.data.waypoints, 'waypoint count');
      check(r.voxels > 0, 'no anatomy voxels');
      Object.assign(metrics, { waypoints: r.n, voxels: r.voxels, bands: r.bands, slider_step_ms: r.stepMs, js_setup_ms: r.jsLoadMs });
      // Play button toggles.
      // The play button starts and stops the animation (clicked through the DOM: software WebGL makes
      // pointer-event actionability waits slow).
      const played = await page.evaluate(async () => {
        const c = window.ctrReport;
        c.setWaypoint(0);
        document.getElementById('play').click();
        for (let t = 0; t < 80 && c.current() === 0; ++t) await new Promise((r) => setTimeout(r, 100));
        document.getElementById('play').click();
        return c.current();
      });
      check(r.n === 1 || played > 0, 'the play button does not advance the path');
      await page.evaluate((k) => { window.ctrReport.setWaypoint(k); return window.ctrReport.nextFrame(); }, Math.floor((r.n - 1) * 0.75));
    }
    await page.screenshot({ path: opt.png, fullPage: opt.kind !== 'planning' });
    if (opt.metrics) fs.writeFileSync(opt.metrics, JSON.stringify(metrics, null, 1) + '\n');
    console.log('metrics ' + JSON.stringify(metrics));
    console.log('screenshot ' + opt.png);
  } finally {
    await browser.close();
    fs.rmSync(profile, { recursive: true, force: true });
  }
  if (problems.length) fail(problems.join('\n'));
  console.log('PASS');
})().catch((e) => fail(String(e && e.stack ? e.stack : e)));
