// Entry point: the page's app, and window.robotrial for scripts and tests.

import "./style.css";
import { RobotrialApp } from "./app";
import { installWindowApi } from "./state";

const app = new RobotrialApp(
  document.getElementById("view") as HTMLElement,
  document.getElementById("panel") as HTMLElement,
);
installWindowApi(
  () => app.state(),
  (seconds) => app.measurePhysics(seconds),
);
void app.start();
