// Vite builds the page into the Python package (src/robotrial/app/static), which
// `robotrial serve` serves. `npm run dev` proxies the API and rosbridge to a running
// `robotrial serve` on port 8000.
import { defineConfig } from "vite";

const server = "http://127.0.0.1:8000";

export default defineConfig({
  base: "/",
  build: {
    outDir: "../src/robotrial/app/static",
    emptyOutDir: true,
    target: "es2022",
    chunkSizeWarningLimit: 1500,
  },
  server: {
    proxy: {
      "/api": server,
      "/rosbridge": { target: server.replace("http", "ws"), ws: true },
    },
  },
});
