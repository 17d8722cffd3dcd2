// Drives Debian's Chromium (headless, through playwright-core from web/node_modules) over the
// web map and checks what a user would see. Throws an Error naming the failed expectation.
import { createRequire } from 'node:module';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const webRequire = createRequire(path.join(here, '../../web/package.json'));

export function check(ok, what) {
  if (!ok) throw new Error(`expectation failed: ${what}`);
}

// Returns a BrowserContext; close it to end Chromium.
export async function launchChromium(outDir) {
  let chromium;
  try {
    ({ chromium } = webRequire('playwright-core'));
  } catch {
    throw new Error('playwright-core not found in web/node_modules: run tools/build-web.sh first');
  }
  const exe = process.env.MAPDELTA_CHROMIUM || '/usr/bin/chromium';
  if (!fs.existsSync(exe)) throw new Error(`${exe} missing: deploy/install-deps.sh installs Debian's chromium`);
  const profile = fs.mkdtempSync(path.join(outDir, 'chromium-profile-'));
  // A fresh, empty profile (--user-data-dir) per run; playwright passes it to Chromium.
  return chromium.launchPersistentContext(profile, {
    executablePath: exe,
    headless: true,
    viewport: { width: 1400, height: 860 },
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync',
      '--enable-unsafe-swiftshader'],
  });
}

// Counts canvas pixels near each reference colour (RGB), reading the WebGL drawing buffer
// (kept by preserveDrawingBuffer) through a 2D canvas.
export async function canvasColourCounts(page, selector, refs, tol = 40) {
  return page.evaluate(({ selector, refs, tol }) => {
    const src = document.querySelector(selector);
    const c = document.createElement('canvas');
    c.width = src.width; c.height = src.height;
    const g = c.getContext('2d');
    g.drawImage(src, 0, 0);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    const counts = Object.fromEntries(Object.keys(refs).map((k) => [k, 0]));
    for (let i = 0; i < d.length; i += 4) {
      for (const [k, [r, gg, b]] of Object.entries(refs)) {
        if (Math.abs(d[i] - r) + Math.abs(d[i + 1] - gg) + Math.abs(d[i + 2] - b) <= tol) counts[k]++;
      }
    }
    counts.total = c.width * c.height;
    return counts;
  }, { selector, refs, tol });
}
