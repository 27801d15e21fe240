// Drives Debian's Chromium (headless) on the preview page for tests/preview.rs.
//
//   node preview.mjs URL
//
// Opens URL, prints "ready" once the page has loaded, then answers one command per
// line on stdin, each with one line on stdout:
//   trace              -> JSON: the page's window.onomatoTrace, the connection label,
//                         and every console error (with the address it is about) and
//                         uncaught exception so far
//   screenshot PATH    -> "ok" once a PNG of the page is written to PATH
//   quit               -> closes the browser and exits
import { chromium } from "playwright-core";
import readline from "node:readline";

const url = process.argv[2];
const browser = await chromium.launch({
  executablePath: "/usr/bin/chromium",
  args: ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"],
});
const page = await browser.newPage({ viewport: { width: 1000, height: 560 } });
const errors = [];
page.on("console", m => {
  if (m.type() === "error") errors.push({ text: m.text(), url: m.location().url });
});
page.on("pageerror", e => errors.push({ text: `exception: ${e.message}`, url: "" }));
await page.goto(url);
console.log("ready");

const lines = readline.createInterface({ input: process.stdin });
for await (const line of lines) {
  const [command, arg] = line.trim().split(/\s+(.*)/);
  if (command === "trace") {
    const trace = await page.evaluate(() => window.onomatoTrace);
    const connection = await page.textContent("#connection");
    console.log(JSON.stringify({ trace, connection, errors }));
  } else if (command === "screenshot") {
    await page.screenshot({ path: arg });
    console.log("ok");
  } else if (command === "quit") {
    break;
  } else {
    console.log(JSON.stringify({ error: `unknown command '${command}'` }));
  }
}
await browser.close();
