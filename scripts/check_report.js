// Opens an HTML page in headless Chromium (Debian's /usr/bin/chromium, driven by npm's
// playwright-core, both installed by `make setup`), takes a full-page screenshot and prints one
// JSON line: {page, images, brokenImages, missingAlt, consoleErrors, failedRequests}.
// Exit status 1 if an image did not load, lacks alt text, or the console holds an error.
//
//   node scripts/check_report.js PAGE.html SCREENSHOT.png
const path = require("path");
const { chromium } = require("playwright-core");

async function main(page_file, screenshot) {
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
    // Chromium's background services would try the network, which test machines lack.
    args: ["--no-sandbox", "--disable-gpu", "--disable-background-networking",
           "--disable-component-update", "--disable-sync", "--no-first-run"],
  });
  const consoleErrors = [], failedRequests = [];
  try {
    const page = await browser.newPage({ viewport: { width: 1280, height: 900 } });
    page.on("console", (message) => {
      if (message.type() === "error") consoleErrors.push(message.text());
    });
    page.on("pageerror", (error) => consoleErrors.push(String(error)));
    page.on("requestfailed", (request) => failedRequests.push(request.url()));
    await page.goto("file://" + path.resolve(page_file), { waitUntil: "load" });
    const images = await page.$$eval("img", (all) => all.map((img) => ({
      src: img.getAttribute("src"), alt: img.getAttribute("alt") || "",
      loaded: img.complete && img.naturalWidth > 0,
    })));
    await page.screenshot({ path: screenshot, fullPage: true });
    const brokenImages = images.filter((img) => !img.loaded).map((img) => img.src);
    const missingAlt = images.filter((img) => !img.alt.trim()).map((img) => img.src);
    console.log(JSON.stringify({ page: page_file, images: images.length, brokenImages,
                                 missingAlt, consoleErrors, failedRequests }));
    return brokenImages.length + missingAlt.length + consoleErrors.length === 0;
  } finally {
    await browser.close();
  }
}

main(process.argv[2], process.argv[3]).then(
  (ok) => process.exit(ok ? 0 : 1),
  (error) => { console.log(JSON.stringify({ error: String(error) })); process.exit(1); });
