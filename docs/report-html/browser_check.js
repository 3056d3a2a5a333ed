// Opens a validation's report.html in headless Chromium, steps through one world stepper with
// its buttons and the arrow keys, prints what it saw as JSON and writes a screenshot of the
// stepper. Exits 1 on a script error in the page or a stepper that does not step.
//
//   npm install playwright-core@1          (once, anywhere; apt-get install chromium)
//   node docs/report-html/browser_check.js OUT/report.html mapkeeper-worlds-seed-11 shot.png
const { chromium } = require('playwright-core');
const path = require('path');

(async () => {
  const [page_file, stepper, shot] = process.argv.slice(2);
  if (!page_file || !stepper || !shot) {
    console.error('usage: browser_check.js REPORT.html STEPPER-ID SHOT.png');
    process.exit(2);
  }
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  const page = await browser.newPage({ viewport: { width: 1400, height: 1000 } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  await page.goto('file://' + path.resolve(page_file));
  const sec = page.locator('section#' + stepper);
  await sec.scrollIntoViewIfNeeded();
  const worlds = await sec.locator('figure').evaluateAll((fs) => fs.map((f) => Number(f.dataset.world)));
  const first = await sec.locator('.label').textContent();
  await sec.locator('button[data-step="1"]').click();
  const shown_after_next = await sec.locator('figure:not([hidden])').getAttribute('data-world');
  await sec.focus();
  await page.keyboard.press('ArrowLeft');
  const shown_after_left = await sec.locator('figure:not([hidden])').getAttribute('data-world');
  await sec.locator('button[data-step="1"]').click();
  await sec.screenshot({ path: shot });
  const report = { worlds, first, shown_after_next, shown_after_left, errors };
  console.log(JSON.stringify(report));
  await browser.close();
  const steps = worlds.length < 2
    || (Number(shown_after_next) === worlds[1] && Number(shown_after_left) === worlds[0]);
  process.exit(errors.length === 0 && steps ? 0 : 1);
})();
