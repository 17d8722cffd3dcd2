// Builds index.html + src/ into dist/, which mapdelta-server serves at `/`. Relative asset
// paths so the page also works behind a reverse proxy under a sub-path.
import { defineConfig } from 'vite';

export default defineConfig({
  base: './',
  build: { outDir: 'dist', emptyOutDir: true, chunkSizeWarningLimit: 1000 },
});
