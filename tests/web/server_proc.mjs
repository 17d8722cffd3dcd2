// Starts the real mapdelta-server for a test: fresh config + SQLite database in `dir`, tokens
// made with its CLI, `serve --port 0` (a free loopback port, read from its "listening on"
// line), the web map mounted with --web-root. stop() sends SIGTERM and waits for exit 0.
import { execFileSync, spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';

export async function startServer({ bin, webRoot, dir, log }) {
  const config = path.join(dir, 'server.yaml');
  fs.writeFileSync(config, [
    'http:', '  listen_address: 127.0.0.1', '  port: 0', '  threads: 4',
    'storage:', `  database: ${JSON.stringify(path.join(dir, 'mapdelta.db'))}`,
    'log:', '  level: info', '  format: text',
    'pipeline:', '  threads: 2', '',
  ].join('\n'));
  const tokens = {};
  for (const role of ['admin', 'reader', 'vehicle']) {
    const out = execFileSync(bin, ['token', 'create', '--config', config, '--role', role, '--name', `web-e2e-${role}`],
      { encoding: 'utf8' });
    const m = /^token: (\S+)$/m.exec(out);
    if (!m) throw new Error(`token create (${role}) printed no "token:" line: ${out}`);
    tokens[role] = m[1];
  }
  const logFile = path.join(dir, 'server.log');
  const errFd = fs.openSync(logFile, 'w');
  const proc = spawn(bin, ['serve', '--config', config, '--web-root', webRoot], { stdio: ['ignore', 'pipe', errFd] });
  const exited = new Promise((resolve) => proc.on('exit', (code, signal) => resolve({ code, signal })));
  const base = await new Promise((resolve, reject) => {
    let out = '';
    const timer = setTimeout(() => reject(new Error(`server did not print "listening on" within 20 s; see ${logFile}`)), 20000);
    proc.stdout.on('data', (d) => {
      out += d;
      const m = /listening on ([\d.]+):(\d+)/.exec(out);
      if (m) { clearTimeout(timer); resolve(`http://${m[1]}:${m[2]}`); }
    });
    exited.then(({ code, signal }) => {
      clearTimeout(timer);
      reject(new Error(`server exited early (code ${code}, signal ${signal}); see ${logFile}`));
    });
  });
  log(`server up at ${base} (log: ${logFile})`);
  return {
    base, tokens, logFile,
    async stop() {
      if (proc.exitCode !== null) return;
      proc.kill('SIGTERM');
      const timeout = new Promise((r) => setTimeout(() => r(null), 15000));
      const r = await Promise.race([exited, timeout]);
      if (!r) { proc.kill('SIGKILL'); throw new Error('server did not stop within 15 s of SIGTERM'); }
      if (r.code !== 0) throw new Error(`server exit code ${r.code} (signal ${r.signal}) after SIGTERM; see ${logFile}`);
      log('server stopped cleanly');
    },
  };
}
